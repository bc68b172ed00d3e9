"""Where the bust's refinement loses (bench multi (a); BENCHMARKS "The outline of several projectors": with the
blurred-bit fill the rounds stop after 2 steps). Runs the refinement on the inner bust for a fixed number of rounds
(no gain stop) and keeps each round's per-pixel error; then sorts the pixels whose error grew in the step after the
first by what they are: dense (the camera sees many projector pixels in one of its pixels: grazing, the filled
regions), shared (a projector pixel that camera pixels far apart in the camera image land on: a fold), near an
overlap edge, or none of these.
Run: .venv/bin/python tools/research/multi_refine_where.py [out_folder] [rounds]  (about 2 minutes)"""
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
from lapig.tools.bench.seams import near_edges
from lapig.lapig_core.refine.loop import RefineSettings
from lapig.lapig_core.common.psnr import masked_psnr

_ensure_registered()
B.FILL_BLURRED_BITS = os.environ.get("STRICT") != "1"  # STRICT=1: the strict decode, for comparison
out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_refine_where")
rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 5
os.makedirs(out, exist_ok=True)
scene, projectors, camera, target = B._bust(os.path.join(out, "scene"), (800, 600))
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "bust")
try:
    model = rig.model
    look = B._in_reach(B._look(model.shape, lo=0.0, hi=1.0), *reach(model))
    valid = rig.inner
    start = joint_compensate(model, look, blend_weights(model.maps)).frames
    ref = JointRefinement(model, look, valid, start, RefineSettings(iterations=rounds, max_repeats=2,
                                                                    stop_gain_db=-100.0))
    capture = device_capture(rig.device)
    errors, psnrs = [], []
    while not ref.done:
        images, repeats = ref.request()
        caps = capture(images, repeats)
        errors.append(((caps.mean(0) - ref.target) ** 2).mean(-1))
        psnrs.append(round(masked_psnr(caps[0], ref.target, valid), 3))
        ref.take(caps)
    # what the pixels are
    dense = np.zeros(model.shape, bool)
    shared = np.zeros(model.shape, bool)
    for m in model.maps:
        d = m.density()
        dense |= m.valid & (d > 4.0)
        # a projector pixel's camera pixels: their spread in the camera image, splatted back per camera pixel
        h, w = m.projector_size[1], m.projector_size[0]
        yy, xx = np.mgrid[0:m.camera_shape[0], 0:m.camera_shape[1]].astype(np.float32)
        sums, wt = m.splat(np.stack([xx, yy, xx * xx, yy * yy], -1))
        mean = sums / np.maximum(wt, 1e-9)[..., None]
        var = np.clip(mean[..., 2] - mean[..., 0] ** 2, 0, None) + np.clip(mean[..., 3] - mean[..., 1] ** 2, 0, None)
        spread = m.sample(np.sqrt(var))  # camera pixels: how far apart the others on their projector pixel lie
        shared |= m.valid & (spread > 2.0)
    edges = near_edges(model.reached, valid, 8.0)
    res = {"fill": B.FILL_BLURRED_BITS, "psnr_per_round": psnrs, "inner_pixels": int(valid.sum()), "classes": {},
           "error_sum_per_round": [], "top_2pct_share_per_round": []}
    for e in errors:
        v = np.sort(e[valid])[::-1]
        res["error_sum_per_round"].append({"all": round(float(v.sum()), 4), **{
            name: round(float(e[valid & cls].sum()), 4) for name, cls in (("shared", shared), ("edges", edges))}})
        res["top_2pct_share_per_round"].append(round(float(v[:max(1, len(v) // 50)].sum() / v.sum()), 3))
    e1 = errors[1] if len(errors) > 1 else errors[0]
    cv2.imwrite(os.path.join(out, "error_round_1.png"),
                cv2.resize((np.clip(np.sqrt(e1) * 8, 0, 1) * valid * 255).astype(np.uint8), None, fx=3, fy=3,
                           interpolation=cv2.INTER_NEAREST))
    for r in range(1, len(errors)):
        grew = valid & (errors[r] > errors[r - 1] * 1.5) & (errors[r] > 1e-4)
        row = {"grew": int(grew.sum()),
               "grew_error_added": round(float((errors[r] - errors[r - 1])[grew].sum()), 4),
               "all_error_change": round(float((errors[r] - errors[r - 1])[valid].sum()), 4)}
        for name, cls in (("dense", dense), ("shared", shared), ("near_overlap_edge", edges)):
            row[name] = {"pixels": int((valid & cls).sum()), "grew": int((grew & cls).sum()),
                         "error_change": round(float((errors[r] - errors[r - 1])[valid & cls].sum()), 4)}
        none = valid & ~dense & ~shared & ~edges
        row["none"] = {"pixels": int(none.sum()), "grew": int((grew & none).sum()),
                       "error_change": round(float((errors[r] - errors[r - 1])[none].sum()), 4)}
        res["classes"][f"round_{r}_vs_{r - 1}"] = row
        if r <= 3:
            vis = np.zeros(model.shape + (3,), np.float32)
            vis[..., 0] = np.clip((errors[r] - errors[r - 1]) * 200, 0, 1) * valid  # red: grew
            vis[..., 1] = np.clip((errors[r - 1] - errors[r]) * 200, 0, 1) * valid  # green: fell
            vis[..., 2] = 0.35 * (dense & valid) + 0.2 * (shared & valid)
            cv2.imwrite(os.path.join(out, f"error_change_{r}.png"),
                        cv2.resize((vis[..., ::-1] * 255).astype(np.uint8), None, fx=3, fy=3,
                                   interpolation=cv2.INTER_NEAREST))
    res["record"] = {k: v for k, v in ref.record.to_dict().items() if k in ("open_loop_psnr", "refined_psnr",
                                                                           "iterations", "stopped")}
finally:
    rig.close()
with open(os.path.join(out, "refine_where.json"), "w") as f:
    json.dump(res, f, indent=1)
print(json.dumps(res))
