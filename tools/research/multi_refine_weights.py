"""Does the fill's cost in refinement come from the blend weights? (BENCHMARKS "The outline of several projectors")
The bust captured with the strict decode (its blend weights kept) and with the fill; the filled rig refined inside
with its own weights and with the strict decode's where that one reaches, with the filled pixels compared and not.
Run: .venv/bin/python tools/research/multi_refine_weights.py  (about 3 minutes)"""
import importlib.util, sys, os, pathlib, json
import numpy as np, cv2
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli.commands import _ensure_registered
from lapig.lapig_core.multi.joint_solve import joint_compensate, reach
from lapig.lapig_core.multi.blend import blend_weights
from lapig.lapig_core.refine.joint import JointRefinement, device_capture, run
from lapig.lapig_core.refine.loop import RefineSettings
_ensure_registered()
out = sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_refine_weights"
B.FILL_BLURRED_BITS = False
scene, projectors, camera, target = B._bust(os.path.join(out, "scene_s"), (800, 600))
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures_s"), "bust")
w_strict = blend_weights(rig.model.maps)
reached_strict = rig.model.reached.any(axis=0)
rig.close()
B.FILL_BLURRED_BITS = True
scene, projectors, camera, target = B._bust(os.path.join(out, "scene_f"), (800, 600))
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures_f"), "bust")
model = rig.model
look = B._in_reach(B._look(model.shape, lo=0.0, hi=1.0), *reach(model))
filled = rig.mask & ~reached_strict
cap = device_capture(rig.device)
w_f = blend_weights(model.maps)
w_mix = np.where(reached_strict[None], w_strict, w_f)
w_mix = w_mix / np.maximum(w_mix.sum(0, keepdims=True), 1e-6)
for name, valid, w in (("default", rig.inner, w_f), ("strict_weights", rig.inner, w_mix),
                       ("no_filled_valid", rig.inner & ~filled, w_f), ("no_filled_strict_weights", rig.inner & ~filled, w_mix)):
    start = joint_compensate(model, look, w).frames
    r = JointRefinement(model, look, valid, start, RefineSettings(iterations=6, max_repeats=2), weights=w)
    rec = run(r, cap)
    print(name, [round(h, 2) for h in rec.history], flush=True)
rig.close()
