"""The bust of `bench multi` in one run four ways: the strict Gray-code decode and projector images black off
their footprint (the old path); the blurred bits filled (multi/graycode_fill); and both with the images' edges
carried 2 % and 4 % of the frame past the footprint (camera_map.BLEED_SHARE); and the strict decode with the 2 %
bleed. Coverage, the joint
compensation's rendered PSNR, seams, refinement and where the error lies, side by side (BENCHMARKS "Several
projectors"). Run: .venv/bin/python tools/research/multi_fill_compare.py [out_folder]  (about 5 minutes)"""
import importlib.util, sys, os, pathlib, json
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli.commands import _ensure_registered
from lapig.tools.bench.machine_figure import machine_speed
from lapig.lapig_core.multi import camera_map

_ensure_registered()
out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_fill_compare")
B.BENCHMARKS = out  # the sheets go here, not over the bench's own
keys = ("coverage_single", "coverage_joint", "coverage_joint_inner", "psnr_joint", "psnr_joint_inner", "singles",
        "joint_gain_db", "joint_gain_db_inner", "seam_ratio", "seam_ratio_inner", "refine", "refine_gain_db_multi",
        "refine_inner", "refine_gain_db_multi_inner", "capture_s", "first_look_seconds", "error_share")
result = {"machine": machine_speed()}
WAYS = (("strict", False, 0.0), ("filled", True, 0.0), ("filled_bleed_2pct", True, 0.02), ("filled_bleed_4pct", True, 0.04),
        ("strict_bleed_2pct", False, 0.02))
only = os.environ.get("WAYS")  # e.g. WAYS=strict_bleed_2pct: those ways only
for name, fill, bleed in [w for w in WAYS if not only or w[0] in only.split(",")]:
    B.FILL_BLURRED_BITS = fill
    camera_map.BLEED_SHARE = bleed
    os.makedirs(os.path.join(out, name), exist_ok=True)
    B.BENCHMARKS = os.path.join(out, name)
    res = B._run_bust(os.path.join(out, name), (800, 600), refine_iterations=6)
    result[name] = {k: res.get(k) for k in keys}
with open(os.path.join(out, "compare_" + (only or "all").replace(",", "_") + ".json"), "w") as f:
    json.dump(result, f, indent=1)
print(json.dumps(result))
