"""Why the bust's outline is not reached (BENCHMARKS "Several projectors", coverage_joint): the Gray code of
each projector rendered in the bench's Cycles studio, decoded, and the object pixels no projector decodes
sorted by cause: white minus black below the threshold (the light does not reach them) or some bit below the
bit threshold; and how many multi/graycode_fill registers, for caps of 4 to 7 unread bits. Writes a sheet of
the causes (grey: decoded, green: filled, red: faint, yellow: blurred and left).
Run: .venv/bin/python tools/research/multi_outline.py [out_folder]"""
import importlib.util, sys, os, pathlib, json
import numpy as np
import cv2
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli.commands import _ensure_registered
_ensure_registered()
from lapig.lapig_addon.blender.cycles_multi_device import CyclesMultiDevice
from lapig.lapig_core.capture.structured_light import graycode_patterns, decode_graycode, decode_graycode_partial, _gray_8bit
from lapig.lapig_core.multi.graycode_fill import fill_unread_bits

out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "/tmp/multi_outline")
os.makedirs(out, exist_ok=True)
size = (800, 600)
scene, projectors, camera, target = B._bust(os.path.join(out, "scene"), size)
dev = CyclesMultiDevice(scene, projectors, camera, target, samples=1, ambient=0.03)
dev.__enter__()
whites = [np.full((h, w, 3), 255, np.uint8) for (w, h) in [size, size]]
dev.lock_exposure(whites)
mask = dev.object_mask()
inner = cv2.erode(mask.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
outline = mask & ~inner
report = {"object": int(mask.sum()), "outline": int(outline.sum())}
decoded_all, contrast_all, filled_all = [], [], []
for k in range(2):
    pats = graycode_patterns(*size)
    frames = [[np.repeat(p[..., None], 3, -1) if j == k else None for j in range(2)] for p in pats]
    caps = []
    for s in range(0, len(frames), 8):
        caps += dev.capture(frames[s:s + 8])
    n = len(caps)
    d = decode_graycode(caps, *size)
    contrast = _gray_8bit(caps[-2], n - 2) - _gray_8bit(caps[-1], n - 1)
    # the weakest bit's |pattern - complement|
    weakest = np.full(mask.shape, 1e9, np.float32)
    for i in range(0, n - 2, 2):
        weakest = np.minimum(weakest, np.abs(_gray_8bit(caps[i], i) - _gray_8bit(caps[i + 1], i + 1)))
    np.savez_compressed(os.path.join(out, f"decode_{k}.npz"), px=d.proj_x, py=d.proj_y, valid=d.valid,
                        contrast=contrast, weakest=weakest)
    decoded_all.append(d.valid); contrast_all.append(contrast)
    partial = decode_graycode_partial(caps, *size)
    for cap in (4, 5, 6, 7):
        report.setdefault("joint_by_cap", {}).setdefault(cap, []).append(fill_unread_bits(d, partial, cap).decoded.valid)
    filled = fill_unread_bits(d, partial)
    filled_all.append(filled.decoded.valid)
    report[f"filled_{k + 1}"] = {"added": int(filled.filled.sum()), "added_on_object": int((filled.filled & mask).sum())}
    report[f"projector_{k + 1}"] = {
        "decoded_object": round(float((d.valid & mask).sum() / mask.sum()), 4),
        "decoded_outline": round(float((d.valid & outline).sum() / outline.sum()), 4),
        "outline_contrast_median": round(float(np.median(contrast[outline])), 1),
        "inner_contrast_median": round(float(np.median(contrast[inner])), 1),
    }
any_dec = np.any(decoded_all, 0)
miss = mask & ~any_dec
best_contrast = np.max(contrast_all, 0)
report["missed"] = int(miss.sum())
report["missed_in_outline"] = int((miss & outline).sum())
report["missed_contrast_below_20"] = int((miss & (best_contrast <= 20)).sum())
report["missed_contrast_20_to_40"] = int((miss & (best_contrast > 20) & (best_contrast <= 40)).sum())
report["missed_contrast_above_40"] = int((miss & (best_contrast > 40)).sum())
report["coverage_joint_filled"] = round(float((np.any(filled_all, 0) & mask).sum() / mask.sum()), 4)
report["coverage_single_filled"] = [round(float((f & mask).sum() / mask.sum()), 4) for f in filled_all]
report["coverage_joint_by_cap"] = {c: round(float((np.any(v, 0) & mask).sum() / mask.sum()), 4)
                                   for c, v in report.pop("joint_by_cap").items()}
report["coverage_joint"] = round(float((any_dec & mask).sum() / mask.sum()), 4)
sheet = np.zeros(mask.shape + (3,), np.uint8)
sheet[mask] = (60, 60, 60)
sheet[any_dec & mask] = (200, 200, 200)
sheet[miss & (best_contrast <= 20)] = (0, 0, 255)
sheet[miss & (best_contrast > 20)] = (0, 200, 255)
sheet[miss & np.any(filled_all, 0)] = (0, 160, 0)
cv2.imwrite(os.path.join(out, "outline_causes.png"), cv2.resize(sheet, None, fx=3, fy=3, interpolation=cv2.INTER_NEAREST))
dev.close()
print(json.dumps(report))
