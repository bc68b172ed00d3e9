"""Each round of the bust's refinement (bench multi (a)), on the whole object, inside and on the pixels only the
blurred-bit fill registers, with those pixels compared and left out (BENCHMARKS "The outline of several
projectors"). Needs tools/research/multi_outline.py's strict decodes (decode_0.npz, decode_1.npz in its out folder).
Run: .venv/bin/python tools/research/multi_outline.py /tmp/multi_outline &&
     .venv/bin/python tools/research/multi_refine_rounds.py [/tmp/multi_outline] [out_folder]"""
import importlib.util, sys, os, pathlib, json
import numpy as np, cv2
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli.commands import _ensure_registered
from lapig.lapig_core.multi.joint_solve import joint_compensate, reach
from lapig.lapig_core.multi.blend import blend_weights
from lapig.lapig_core.refine.joint import JointRefinement, device_capture
from lapig.lapig_core.refine.loop import RefineSettings
from lapig.lapig_core.common.psnr import masked_psnr
_ensure_registered()
decodes = sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_outline"
out = sys.argv[2] if len(sys.argv) > 2 else "/tmp/multi_refine_rounds"
scene, projectors, camera, target = B._bust(os.path.join(out, "scene"), (800, 600))
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "bust")
model = rig.model
look = B._in_reach(B._look(model.shape, lo=0.0, hi=1.0), *reach(model))
strict = np.any([np.load(os.path.join(decodes, f"decode_{k}.npz"))["valid"] for k in range(2)], 0)
filled = rig.mask & ~strict
print("filled px", filled.sum())
cap_fn = device_capture(rig.device)
for name, valid in (("all", rig.mask), ("without_filled", rig.mask & ~filled), ("inner", rig.inner), ("inner_without_filled", rig.inner & ~filled)):
    start = joint_compensate(model, look, blend_weights(model.maps)).frames
    r = JointRefinement(model, look, valid, start, RefineSettings(iterations=6, max_repeats=2))
    rounds = []
    while not r.done:
        frames, reps = r.request()
        caps = cap_fn(frames, reps)
        c = caps[0]
        rounds.append({"all": round(masked_psnr(c, r.target, rig.mask), 2), "inner": round(masked_psnr(c, r.target, rig.inner & ~filled), 2),
                       "filled": round(masked_psnr(c, r.target, filled), 2)})
        r.take(caps)
    print(name, r.record.stopped, r.record.history, rounds)
rig.close()
