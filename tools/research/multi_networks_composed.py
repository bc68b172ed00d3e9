"""Networks per projector composed with the joint solve, on bench multi's bust (a) (issue 36, BENCHMARKS "Several
projectors": do networks per projector earn their cost?).

multi_networks_per_projector.py trained CompenNeSt for each bust projector alone (a one-projector capture at its
pose, the app's Train). Here those networks compensate the joint solve's share of each projector:
  1. the bench's capture of both projectors and its joint classical compensation of the bench's look;
  2. projector k's share: the joint drives q_k alone, as the joint model predicts projector k's capture of them
     (f_c(M_k q_k + o): the camera image projector k alone must make);
  3. that image registered into projector k's frame at 800x600 by its one-projector capture's registration, and
     compensated there by its one-projector CompenNeSt, and (to tell the network from the route) by the same
     capture's classical model;
  4. both composed images rendered at once in the bench's Cycles studio, against the look; and a hybrid: the
     network's pixels where its one-projector capture registered the projector, the joint classical image's
     elsewhere (that capture's strict decode, without the multi capture's fill, leaves the grazing regions out).
PSNRs on the object, on it without its 2 px outline ("inner"), and on the inner pixels every reaching projector's
one-projector capture registered ("covered": where the networks can be judged).
The one-projector captures locked their exposure on one projector's white (-1.68 stops), the joint one on both
(-1.71): 2 % of linear light, left as it is. The composed images are black where the one-projector registration
saw none of the projector's light (the app's dark_outside); the joint images carry their edge 2 % past it.
Run: .venv/bin/python tools/research/multi_networks_composed.py NETS_FOLDER [out_folder]
  (NETS_FOLDER: multi_networks_per_projector.py's output folder, with bust_projector_<k>_lapig/; about 2 minutes)"""
import importlib.util, sys, os, pathlib, json, time
import numpy as np
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
import cv2
import torch
from lapig.tools.bench import bench_multi as B
from lapig.lapig_addon.cli.commands import _ensure_registered
from lapig.lapig_core.capture.native_references import registered_references
from lapig.lapig_core.capture.registration import Registration
from lapig.lapig_core.multi.blend import blend_weights
from lapig.lapig_core.multi.joint_solve import joint_compensate, reach
from lapig.tools.bench.seams import psnr_on
from lapig.lapig_core.native_output import compensate_frame, tile_for
from lapig.lapig_core.photometric.classical_compensator import ClassicalCompensator
from lapig.lapig_core.photometric.training_data import to_tensor
from lapig.lapig_core.pipeline import load_saved_models

nets = os.path.abspath(sys.argv[1])
out = os.path.abspath(sys.argv[2] if len(sys.argv) > 2 else "/tmp/multi_networks_composed")
os.makedirs(out, exist_ok=True)
_ensure_registered()
torch.set_grad_enabled(False)
SIZE = (800, 600)

scene, projectors, camera, target = B._bust(os.path.join(out, "scene_bust"), SIZE)
rig = B.Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "bust")
try:
    model, obj = rig.model, rig.object_mask
    inner = cv2.erode(obj.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    look = B._in_reach(B._look(model.shape, lo=0.0, hi=1.0), *reach(model))
    joint = joint_compensate(model, look, blend_weights(model.maps))
    cap_joint = rig.render(joint.frames)
    res = {"psnr_joint_classical": {"object": round(psnr_on(cap_joint, look, obj), 3),
                                    "inner": round(psnr_on(cap_joint, look, inner), 3)}}
    composed = {"compennest": [], "classical": [], "hybrid": []}
    shares, alone_caps = [], {"compennest": [], "classical": [], "joint": []}
    covered = np.ones(model.shape, bool)  # camera pixels every reaching projector's one-projector capture registered
    for k in range(model.count):
        drives = np.zeros_like(joint.drives)
        drives[k] = joint.drives[k]
        share = model.predict_linear(drives)  # the camera image projector k alone must make
        shares.append(share)
        setup = os.path.join(nets, f"bust_projector_{k + 1}_lapig", "LAPIG_demo_statue", "setups", "LAPIG_demo_statue")
        registration = Registration.load(os.path.join(setup, "registration.npz")).resized(*SIZE)
        wanted, valid = registration.warp(share, return_valid=True)
        refs = registered_references(setup, *SIZE)
        saved = load_saved_models(setup)
        for name, comp in (("compennest", saved.compensation), ("classical", ClassicalCompensator(saved.classical))):
            comp = comp.eval()
            img = compensate_frame(comp, to_tensor(wanted[None]), to_tensor(refs.gray[None]), tile_for(*SIZE))
            img = img[0].permute(1, 2, 0).clamp(0, 1).numpy() * (valid & refs.valid)[..., None]
            composed[name].append(img.astype(np.float32))
        # the hybrid: CompenNeSt where its capture registered the projector's pixels, the joint classical elsewhere
        ok = (valid & refs.valid)[..., None]
        composed["hybrid"].append(np.where(ok, composed["compennest"][k], joint.frames[k]).astype(np.float32))
        seen = model.maps[k].sample((valid & refs.valid).astype(np.float32)) > 0.99
        covered &= ~model.maps[k].valid | seen
        alone_caps["joint"].append(rig.alone(k, joint.frames[k]))
        for name in ("compennest", "classical"):
            alone_caps[name].append(rig.alone(k, composed[name][k]))
    # each projector's share alone: how well each route makes the camera image asked of it
    both = inner & covered & model.reached.any(axis=0)
    res["covered_share_of_inner"] = round(float(both.sum() / max(1, inner.sum())), 4)
    res["alone"] = {name: [{"object": round(psnr_on(c, s, obj), 3), "inner": round(psnr_on(c, s, inner), 3),
                            "covered": round(psnr_on(c, s, both), 3)}
                           for c, s in zip(caps, shares)] for name, caps in alone_caps.items()}
    res["psnr_joint_classical"]["covered"] = round(psnr_on(cap_joint, look, both), 3)
    caps = {}
    for name, frames in composed.items():
        caps[name] = rig.render(frames)
        res[f"psnr_composed_{name}"] = {"object": round(psnr_on(caps[name], look, obj), 3),
                                        "inner": round(psnr_on(caps[name], look, inner), 3),
                                        "covered": round(psnr_on(caps[name], look, both), 3)}
    for key in ("inner", "covered"):
        res[f"gain_compennest_over_joint_classical_db_{key}"] = round(
            res["psnr_composed_compennest"][key] - res["psnr_joint_classical"][key], 3)
        res[f"gain_compennest_over_composed_classical_db_{key}"] = round(
            res["psnr_composed_compennest"][key] - res["psnr_composed_classical"][key], 3)
        res[f"gain_hybrid_over_joint_classical_db_{key}"] = round(
            res["psnr_composed_hybrid"][key] - res["psnr_joint_classical"][key], 3)
    tiles = [(look * obj[..., None], "asked look"),
             (cap_joint, f"joint classical {res['psnr_joint_classical']['inner']:.2f} dB (inner)"),
             (caps["classical"], f"composed classical {res['psnr_composed_classical']['inner']:.2f}"),
             (caps["compennest"], f"composed CompenNeSt {res['psnr_composed_compennest']['inner']:.2f}"),
             (np.clip(np.abs(cap_joint - look) * 4, 0, 1), "joint classical error x4"),
             (np.clip(np.abs(caps["compennest"] - look) * 4 * both[..., None], 0, 1), "its error x4, covered pixels"),
             (caps["hybrid"], f"hybrid {res['psnr_composed_hybrid']['inner']:.2f}"),
             (cv2.resize(composed["compennest"][0], B.CAMERA, interpolation=cv2.INTER_AREA), "projector 1, CompenNeSt"),
             (cv2.resize(joint.frames[0], B.CAMERA, interpolation=cv2.INTER_AREA), "projector 1, joint classical")]
    B.BENCHMARKS = out
    res["sheet"] = B._sheet(os.path.join(out, "networks_composed.jpg"), tiles,
                            "bust (a): per-projector networks composed with the joint solve, rendered in Cycles")
finally:
    rig.close()
with open(os.path.join(out, "networks_composed.json"), "w") as f:
    json.dump(res, f, indent=1)
print(json.dumps(res))
