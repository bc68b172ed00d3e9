"""Where the bust's outline error comes from (BENCHMARKS "Several projectors"): the joint compensation of the
bench's look captured in the Cycles studio, against the joint model's prediction and the target, on the reached
outline (2 px) and inside; the all-white capture against the model's; the same capture twice (noise).
Run: .venv/bin/python tools/research/multi_outline_error.py [out_folder]"""
import importlib.util, sys, os, pathlib, json
import numpy as np
import cv2
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli.commands import _ensure_registered
from lapig.lapig_core.multi.blend import blend_weights
from lapig.lapig_core.multi.joint_solve import joint_compensate, reach

_ensure_registered()
out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_outline_error")
os.makedirs(out, exist_ok=True)
scene, projectors, camera, target = B._bust(os.path.join(out, "scene"), (800, 600))
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "bust")
model, obj = rig.model, rig.object_mask
look = B._in_reach(B._look(model.shape, lo=0.0, hi=1.0), *reach(model))
joint = joint_compensate(model, look, blend_weights(model.maps))
cap = rig.render(joint.frames)
cap2 = rig.render(joint.frames)
pred = model.predict(joint.frames)
white = [np.ones((h, w, 3), np.float32) for (w, h) in (m.projector_size for m in model.maps)]
cap_w = rig.cs.together.astype(np.float32) / 255
pred_w = model.predict(white)
inner = cv2.erode(obj.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
reached = model.reached.any(axis=0)
lo, hi = reach(model)
def rms(a, b, m):
    return round(float(np.sqrt(((a - b) ** 2).mean(-1)[m].mean())), 4)
rep = {}
for name, m in (("outline_reached", obj & ~inner & reached), ("inner_reached", inner & reached)):
    rep[name] = {"pixels": int(m.sum()),
                 "capture_vs_target": rms(cap, look, m), "capture_vs_prediction": rms(cap, pred, m),
                 "prediction_vs_target": rms(pred, look, m), "capture_vs_capture": rms(cap, cap2, m),
                 "white_capture_vs_model": rms(cap_w, pred_w, m),
                 "reach_width": round(float((hi - lo).mean(-1)[m].mean()), 4),
                 "white_capture_mean": round(float(cap_w.mean(-1)[m].mean()), 4)}
# the outline's error by the side of the object (which projector lights it)
share = model.reached.sum(axis=0)
m = obj & ~inner & reached
rep["outline_by_projectors"] = {int(c): rms(cap, look, m & (share == c)) for c in (1, 2)}
err = np.abs(cap - look).mean(-1) * (obj & reached)
cv2.imwrite(os.path.join(out, "outline_error.png"), cv2.resize(np.clip(err * 4 * 255, 0, 255).astype(np.uint8), None, fx=3, fy=3,
            interpolation=cv2.INTER_NEAREST))
errp = np.abs(cap - pred).mean(-1) * (obj & reached)
cv2.imwrite(os.path.join(out, "outline_error_vs_prediction.png"), cv2.resize(np.clip(errp * 4 * 255, 0, 255).astype(np.uint8), None, fx=3, fy=3,
            interpolation=cv2.INTER_NEAREST))
rig.close()
print(json.dumps(rep))
