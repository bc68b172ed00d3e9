"""`python -m lapig_addon bench refine --json`: closed-loop refinement on the rig (issue 27).

Per setup (the five realistic setups and the demo wall, Realistic transport), on `--compensate` held-back
test images made into desired captures (photometric.targets: inside the surface's range):
  * open loop: today's classical compensation (the inverse clipped to [0,1] in projector space), rendered;
  * the box-constrained classical solve (photometric.box_solve), rendered: `box_solve_gain_db` against
    the clipped one on the same targets;
  * refinement (lapig_core.refine) from the box solve, through the Cycles capture device of the setup
    (services.projection, the seam Train's choice and Render Real Capture use), each capture round with a
    seed of its own; the refined images are then rendered once more with a fresh seed and that capture is
    the refined figure (not the captures the loop chose by);
  * the noise floor: the start images captured twice (two seeds), PSNR of one against the other.
Every PSNR is masked (the pixels the projector reaches) against the reachable target (clamped to [I-, I+]).
Side-by-side sheets (target | open loop | refined | errors x4) of the first image per setup go to --out.
"""
from __future__ import annotations

import json
import math
import os
import platform
import time

import numpy as np

from ...lapig_addon.blender.cycles_factory import CyclesDeviceFactory
from ...lapig_addon.services.capture.projection import projection_session
from ...lapig_core.common.atomic import atomic_write_bytes
from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.psnr import masked_psnr
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.photometric.box_solve import box_compensate
from ...lapig_core.photometric.classical import ClassicalModel
from ...lapig_core.photometric.targets import desired_targets, reachable_mask
from ...lapig_core.refine.loop import Refinement, RefineSettings, run as run_loop
from .. import synthetic_setups as syn

# the demo's wall (the demo scene: a panel with the sakura texture), in the realistic transport
DEMO_WALL = syn.SetupSpec("d0_demo_wall", "panel", "sakura", 0, transport="REALISTIC")


def _log(args, msg):
    if not args.json:
        print(msg, flush=True)


def specs_of(args) -> list:
    every = {s.name: s for s in list(syn.REALISTIC_SETUPS) + [DEMO_WALL]}
    if not args.realistic_setups:
        return list(every.values())
    unknown = [n for n in args.realistic_setups if n not in every]
    if unknown:
        raise ValueError(f"unknown setup {', '.join(unknown)}; known: {', '.join(every)}")
    return [every[n] for n in args.realistic_setups]  # in the order named: slow ones can go last


def error_image(capture, target, mask):
    return np.where(mask[..., None], np.clip(np.abs(capture - target) * 4, 0, 1), 0).astype(np.float32)


def _psnr_where(caps, target, where):
    """Masked PSNR over the (N, H, W) selection; None where it selects nothing or matches exactly."""
    value = masked_psnr(caps, target, where)
    return round(value, 4) if math.isfinite(value) else None


def crop_sheet(name, target, open_loop, refined, mask):
    """The object's bounding box, twice the size: target | open loop | refined, errors x8 below."""
    import cv2

    ys, xs = np.nonzero(mask)
    box = (slice(ys.min(), ys.max() + 1), slice(xs.min(), xs.max() + 1))
    up = lambda im: cv2.resize(np.ascontiguousarray(im[box]), None, fx=2, fy=2,  # noqa: E731
                               interpolation=cv2.INTER_NEAREST)
    err = lambda im: np.where(mask[..., None], np.clip(np.abs(im - target) * 8, 0, 1), 0)  # noqa: E731
    change = np.where(mask[..., None], np.clip(np.abs(refined - open_loop) * 8, 0, 1), 0)
    return labelled_grid([up(target), up(open_loop), up(refined), up(change), up(err(open_loop)), up(err(refined))],
                         ["target", "open loop (clipped classical)", "refined on the rig", "what refinement changed x8",
                          "open-loop error x8", "refined error x8"], columns=3, cell=420, title=f"{name}: rendered captures, object crop")


def one_setup(args, data, spec, out) -> dict:
    cs = syn.load_setup(data, spec.name)
    mask = reachable_mask(cs.cam_black, cs.cam_white)
    count = min(args.compensate, len(cs.prj_test))
    targets = desired_targets(cs.prj_test[:count], cs.cam_black, cs.cam_white, mask)
    reachable = np.clip(targets, cs.cam_black, cs.cam_white)
    model = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    scene, projector, camera, target = syn.build_setup(spec, os.path.join(data, "textures"))
    devices = CyclesDeviceFactory(scene, projector, camera, target)
    setup_dir = syn.layout(data, spec.name).setup_dir
    clipped_images = model.compensate(targets)
    t0 = time.perf_counter()
    box_images = box_compensate(model, targets)
    box_s = time.perf_counter() - t0
    # the rig opened once (as Refine on the rig does); every capture round a new Cycles seed (vary_noise)
    with projection_session(devices, setup_dir, seed=1000) as rig:
        def capture(images, repeats=1):
            rounds = [rig.capture(images)[0] for _ in range(repeats)]
            return np.stack(rounds, axis=1).reshape((-1,) + rounds[0].shape[1:])

        clipped = capture(clipped_images)
        refinement = Refinement(model, targets, cs.cam_black, cs.cam_white, mask, box_images,
                                RefineSettings(iterations=args.refine_iterations,
                                                               damping=args.refine_damping))
        first = []

        def loop_capture(images, repeats):
            got = capture(images, repeats)
            if not first:  # the box solve's first capture (the noise pair's first of each image)
                first.append(got[::repeats])
            return got

        record = run_loop(refinement, loop_capture)
        refined = capture(refinement.images)  # a fresh noise draw: the figure is not the loop's own pick
    rounds = len(record.history)
    row = {
        "open_loop_clipped_psnr": round(masked_psnr(clipped, reachable, mask), 4),
        "box_solve_psnr": round(record.open_loop_psnr, 4),
        "refined_psnr": round(masked_psnr(refined, reachable, mask), 4),
        "refined_psnr_loop": round(record.refined_psnr, 4),
        "noise_floor_psnr": round(record.noise_floor_psnr, 4),
        "iterations": record.iterations, "capture_rounds": rounds, "captures": record.captures,
        "repeats": record.repeats, "history": [round(v, 3) for v in record.history], "stopped": record.stopped,
        "refine_s": round(record.seconds, 2), "box_solve_s": round(box_s, 2), "targets": count,
        "reachable_share": round(float((model.reachable(targets) & mask[None]).sum() / max(1, mask.sum() * count)), 4),
        "camera_size": (cs.meta.get("camera") or {}).get("resolution"), "working_frame": cs.meta.get("working_frame"),
        "projector_size": [(cs.meta.get("projector") or {}).get(k) for k in ("width", "height")],
    }
    # a round captures every target (repeats times): the seconds of one iteration for the whole batch
    # where the model says the clamped target is reachable (the box solve needs no bound): the part the
    # goal's "every pixel reachable" is about; the rest is out of the projector's reach whatever it shows
    reach = model.reachable(reachable) & mask[None]
    row["reachable_after_clamp_share"] = round(float(reach.sum() / max(1, mask.sum() * count)), 4)
    for key, caps in (("open_loop_clipped", clipped), ("box_solve", first[0]), ("refined", refined)):
        row[f"{key}_psnr_reachable"] = _psnr_where(caps, reachable, reach)
        row[f"{key}_psnr_unreachable"] = _psnr_where(caps, reachable, mask[None] & ~reach)
    row["seconds_per_iteration"] = round(record.seconds / max(1, rounds), 2)
    row["seconds_per_capture"] = round(record.seconds / max(1, record.captures), 3)
    row["box_solve_gain_db"] = round(row["box_solve_psnr"] - row["open_loop_clipped_psnr"], 4)
    row["refine_gain_db"] = round(row["refined_psnr"] - row["open_loop_clipped_psnr"], 4)
    row["refined_minus_floor_db"] = round(row["refined_psnr"] - row["noise_floor_psnr"], 4)
    i = 0
    write_png(os.path.join(out, f"refine_{spec.name}_crop.png"), crop_sheet(spec.name, reachable[i], clipped[i],
                                                                           refined[i], mask))
    for name, im in (("target", reachable[i]), ("open_loop", clipped[i]), ("refined", refined[i])):
        write_png(os.path.join(out, f"refine_{spec.name}_{name}.png"), im, bit_depth=16)
    sheet = labelled_grid([reachable[i], clipped[i], refined[i], error_image(clipped[i], reachable[i], mask),
                           error_image(refined[i], reachable[i], mask)],
                          ["target (reachable)", f"open loop {masked_psnr(clipped[i:i + 1], reachable[i:i + 1], mask):.1f} dB",
                           f"refined {masked_psnr(refined[i:i + 1], reachable[i:i + 1], mask):.1f} dB",
                           "open-loop error x4", "refined error x4"], columns=5, cell=320,
                          title=f"{spec.name}: rendered captures, open loop against refined on the rig")
    write_png(os.path.join(out, f"refine_{spec.name}.png"), sheet)
    return row


def run(args) -> dict:
    t0 = time.perf_counter()
    out = os.path.abspath(args.out)
    data = os.path.abspath(args.refine_data)
    os.makedirs(out, exist_ok=True)
    specs = specs_of(args)
    per_setup = {}
    for spec in specs:
        _log(args, f"{spec.name}: capturing ({args.train_pairs} training pairs) unless already captured")
        syn.render_synthetic_setups([spec], data, train=args.train_pairs, test=args.compensate, seed=600,
                                    skip_existing=True)
        per_setup[spec.name] = one_setup(args, data, spec, out)
        _log(args, f"  {per_setup[spec.name]}")
        text = json.dumps(per_setup, indent=1, sort_keys=True, default=float)
        atomic_write_bytes(os.path.join(out, "refine_partial.json"), text.encode("utf-8"))  # a crash keeps these
    mean = lambda key: round(float(np.mean([r[key] for r in per_setup.values()])), 4)  # noqa: E731
    summary = {key + "_mean": mean(key) for key in ("open_loop_clipped_psnr", "box_solve_psnr", "refined_psnr",
                                                     "noise_floor_psnr", "iterations", "seconds_per_iteration")}
    summary.update({key: mean(key) for key in ("refined_minus_floor_db", "refine_gain_db", "box_solve_gain_db")})
    summary.update({
        "goals": {"refined_minus_floor_db": ">= -1.5", "refine_gain_db": ">= +3"},
        "open_loop": "the classical compensation clipped in projector space (the app's classical solve before)",
        "start": "the box-constrained classical solve", "per_setup": per_setup, "setups": [s.name for s in specs],
        "train_pairs": args.train_pairs, "targets_per_setup": args.compensate,
        "refine_iterations_cap": args.refine_iterations, "refine_damping": args.refine_damping, "bench_total_s": round(time.perf_counter() - t0, 1),
        "machine": platform.processor() or platform.machine(), "sheets": out})
    if args.machine_speed:
        summary["torch_step_s"] = machine_speed()
    return summary


def machine_speed() -> float | None:
    """/work/shared/machine_speed.py's torch_step_s where the file is (beside the timings), else None."""
    import subprocess
    import sys

    path = os.environ.get("LAPIG_MACHINE_SPEED", "/work/shared/machine_speed.py")
    if not os.path.isfile(path):
        return None
    done = subprocess.run([sys.executable, path], capture_output=True, text=True, check=False)
    try:
        return json.loads(done.stdout.strip().splitlines()[-1])["torch_step_s"]
    except (ValueError, IndexError, KeyError):
        return None

