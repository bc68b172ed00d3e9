"""Each pixel's response to the bust's refinement steps (bench multi (a), inner bust, 3 steps, no gain stop): the
change its capture showed over the change the joint model predicted for it (BENCHMARKS "The outline of several
projectors"). Saves the rounds' linear captures and drives, then prints the response of the pixels that hold the error.
Run: .venv/bin/python tools/research/multi_refine_response.py [out_folder]  (about a minute)"""
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
_ensure_registered()
out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_refine_response")
os.makedirs(out, exist_ok=True)
scene, projectors, camera, target = B._bust(os.path.join(out, "scene"), (800, 600))
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "bust")
model = rig.model
look = B._in_reach(B._look(model.shape, lo=0.0, hi=1.0), *reach(model))
valid = rig.inner
start = joint_compensate(model, look, blend_weights(model.maps)).frames
ref = JointRefinement(model, look, valid, start, RefineSettings(iterations=3, max_repeats=2, stop_gain_db=-100.0))
capture = device_capture(rig.device)
ys, preds, qs = [], [], []
M = model.M.astype(np.float64)
while not ref.done:
    images, repeats = ref.request()
    caps = capture(images, repeats)
    ys.append(np.power(np.clip(caps.mean(0).astype(np.float64), 0, 1), model.gamma_c))
    qs.append(ref.q.copy())
    ref.take(caps)
np.savez_compressed(os.path.join(out, "resp.npz"), y=np.stack(ys), q=np.stack(qs), valid=valid, target=ref.y_target,
                    M=model.M, o=model.o, response=ref.response)
rig.close()

# the response: step n's predicted change of the linear capture against the change the captures showed
y, q, R = np.stack(ys), np.stack(qs), ref.response
M = model.M.astype(np.float64)
lin = lambda qq: np.einsum("khwij,khwj->hwi", M, qq)  # noqa: E731
res = {}
for n in range(1, len(y) - 1):
    asked, seen = R * (lin(q[n]) - lin(q[n - 1])), R * (y[n] - y[n - 1])
    den = (asked * asked).sum(-1)
    g = np.where(den > 0, (asked * seen).sum(-1) / np.maximum(den, 1e-30), np.nan)
    big = valid & (den > np.percentile(den[valid], 50))
    err = ((R * (ref.y_target - y[n])) ** 2).sum(-1)
    top = valid & (err > np.percentile(err[valid], 98))
    off = valid & ((g < 0.3) | (g > 2.0)) & (den > np.percentile(den[valid], 25))
    res[f"step_{n}"] = {"gain_median_large_steps": round(float(np.nanmedian(g[big])), 3),
                        "gain_p10_p50_p90_top_2pct_error": np.nanpercentile(g[top], [10, 50, 90]).round(3).tolist(),
                        "pixels_gain_below_0.3_or_above_2": int(off.sum()),
                        "their_share_of_the_error": round(float(err[off].sum() / err[valid].sum()), 3)}
print(json.dumps(res))
