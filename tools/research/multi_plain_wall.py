"""`bench multi`'s wall (b) on a plain wall: the same two projectors side by side with 18 % overlap, the wall's wood
texture replaced by an even light grey, so the captured white measures the blend and the light's fall-off, not the
wood's stripes (BENCHMARKS "Several projectors", white_uniformity_pct).
With --alpha-gamma G the alpha maps are encoded with G (the studio's projectors follow 2.2) instead of the blend
probe's gammas (and the joint fit's, the old path, beside them).
Run: .venv/bin/python tools/research/multi_plain_wall.py [out_folder] [--alpha-gamma 2.2]  (about a minute)"""
import importlib.util, sys, os, pathlib, json
import numpy as np
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli import headless
from lapig.lapig_addon.cli.commands import _ensure_registered

_ensure_registered()
args = [a for a in sys.argv[1:]]
alpha_gamma = float(args[args.index("--alpha-gamma") + 1]) if "--alpha-gamma" in args else None
if alpha_gamma is not None:
    del args[args.index("--alpha-gamma"):args.index("--alpha-gamma") + 2]
    from lapig.lapig_core.multi import blend
    fitted = blend.encode_alpha
    blend.encode_alpha = lambda alpha, gamma_p: fitted(alpha, alpha_gamma)
out = os.path.abspath(args[0] if args else "/tmp/multi_plain_wall")
os.makedirs(out, exist_ok=True)
B.BENCHMARKS = out  # the sheet goes here, not over the bench's own
grey = np.full((512, 512, 3), 0.8, np.float32)  # an even light grey albedo
build = headless.build_demo_setup
headless.build_demo_setup = lambda *a, **k: build(*a, **{**k, "texture": grey})
res = B._run_wall(out, (400, 300))
keys = [k for k in res if k.startswith("white") or k.startswith("flat") or k in ("psnr_joint", "psnr_halves_single",
                                                                                  "wall_vs_single_db", "seam_ratio", "blend_gamma",
                                                                                  "gamma_p", "gamma_c")]
summary = {k: res[k] for k in keys}
summary["alpha_gamma"] = alpha_gamma or "fitted"
with open(os.path.join(out, "plain_wall.json"), "w") as f:
    json.dump(summary, f, indent=1)
print(json.dumps(summary))
