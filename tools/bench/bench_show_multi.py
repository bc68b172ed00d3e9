# SPDX-License-Identifier: GPL-3.0-or-later
"""`python -m lapig_addon bench show-multi --json`: a show on a rig of several projectors (issues 36 and 38).

The fake rig of two side by side (tools/fakes/fake_rig: each projector's own homography, gamma, gain,
crosstalk and grazing light; 8-bit projectors and camera, noise off so the flicker is the show's) is captured as
the add-on captures it (multi/capture: each projector's Gray code and references, its joint first look). Two looks
are made as Generate of several makes them (multi/stylize.stylize_joint with PSA on the joint reach, written with
their look_state.npz), and the show's frames come from lapig_core/show's producer through show/joint_setup: each
morph and moving frame adapted on the joint reach and split among the projectors by the joint solve. Every
frame's two projector images are "captured" together through the rig. Figures are simulated, not Cycles renders.

    inbetween_psnr_drop_db      4 morph + 4 moving frames captured against their own targets, below the keyed
                                looks' captured PSNR (issue 38's goal: <= 0.5 dB)
    temporal_flicker            issue 38's measure over the morph's and the moving look's consecutive frames,
                                captured; beside it the unadapted frames' and through the joint model (no 8-bit
                                steps, no resampling)
    dissolve_check_db           the crossfade of the looks' frames at a dissolve's midpoint minus the midpoint
                                compensated jointly as its own target
    dissolve_keyed_between_db   the keyed dissolve (the producer's default) at w = 3/8 minus that frame itself
    frames_per_second_moving    moving frames made per second (adapted, jointly solved at the camera's size,
                                split into both projectors' frames), no encoding
"""
from __future__ import annotations

import math
import os
import tempfile
import time

import numpy as np

from ...lapig_core.capture.settings import CaptureSettings
from ...lapig_core.common.psnr import masked_psnr
from ..fakes import fake_rig
from ...lapig_core.multi.capture import run_multi_capture

CAMERA, PROJECTOR = (320, 240), (400, 300)
LOOKS = ("Make it a stained glass artwork", "Make it a charcoal sketch")
FPS = 10
BENCHMARKS = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                          "benchmarks")


def _capture(rig, folder):
    settings = CaptureSettings(out_dir=folder, setup_name="wall", train_count=8, chunk=8)
    gen = run_multi_capture(fake_rig.FakeRigDevice(rig), settings, ["left", "right"], extra_meta={"fingerprint": "b"})
    while True:
        try:
            next(gen)
        except StopIteration as done:
            setup_dir = done.value["setup_dir"]
            break
    from ...lapig_core.multi.capture_set import load_multi_capture
    from ...lapig_core.multi.first_look import fit_joint_first_look

    fit_joint_first_look(load_multi_capture(setup_dir))  # the first look at the capture, as the add-on's job fits it
    return setup_dir


def _looks(setup_dir, results, psa_iterations, working_size):
    from ...lapig_core.multi.capture_set import load_multi_capture
    from ...lapig_core.multi.first_look import load_joint_model
    from ...lapig_core.multi.result_files import write_joint_result
    from ...lapig_core.multi.stylize import stylize_joint
    from ...lapig_core.psa.adaptation import PSASettings

    cs = load_multi_capture(setup_dir, pairs=False)
    model = load_joint_model(cs.setup_dir)
    surface = cs.together.astype(np.float32) / 255
    folders = []
    for n, prompt in enumerate(LOOKS):
        look = stylize_joint(model, surface, prompt, "styletransfer", 0, None, None, working_size, cs.object_mask,
                             psa_settings=PSASettings(seed=0, max_iterations=psa_iterations))
        summary = {"prompt": prompt, "backend": "styletransfer", "seed": 0, "fingerprint": cs.meta.get("fingerprint")}
        folder, _ = write_joint_result(results, f"look{n}", look, surface, cs.names, cs.sizes, summary,
                                       model.reached.any(axis=0) & cs.object_mask)
        folders.append(str(folder))
    return folders


def _flicker(seen, targets, mask) -> float:
    """mean |change of the capture - change of the target| / mean |change of the target|, consecutive frames."""
    num = sum(float(np.abs((seen[n + 1] - seen[n]) - (targets[n + 1] - targets[n]))[mask].mean())
              for n in range(len(seen) - 1))
    den = sum(float(np.abs(targets[n + 1] - targets[n])[mask].mean()) for n in range(len(seen) - 1))
    return num / den if den > 0 else math.nan


def quality_and_speed(setup, folders, rig, sheet_path=None) -> dict:
    from ...lapig_core.show.frames import FrameMaker, FrameSettings
    from ...lapig_core.show.model import Look, Motion, Show, Transition

    a = Look(folders[0], LOOKS[0], "styletransfer", 0, hold_s=0.3)
    b = Look(folders[1], LOOKS[1], "styletransfer", 0, hold_s=2.0, motion=Motion("drift", 0.6, 2.0))
    show = Show([a, b], [Transition("morph", 1.0)], fps=FPS)
    mask = setup.on
    capture = lambda frames: rig.capture(frames).astype(np.float32) / 255  # noqa: E731
    image = lambda t: t[0].permute(1, 2, 0).numpy()  # noqa: E731

    def make_frames(settings):
        maker = FrameMaker(show, setup, settings=settings)
        keys = list(dict.fromkeys(maker.schedule.at(i) for i in range(maker.schedule.total_frames)))
        morph = [k for k in keys if k[0] == "morph"]
        moving = [k for k in keys if k[0] == "moving"][:12]
        used = [k for k in keys if k[0] == "hold"] + morph + moving
        for k in [k for k in keys if k[0] == "hold"] + morph:  # in show order: the warm start follows them
            maker.frame(k)
        t1 = time.perf_counter()
        for k in moving:
            maker.frame(k)
        moving_s = (time.perf_counter() - t1) / len(moving)
        frames = {k: maker.frame(k) for k in used}
        targets = {k: image(maker.target_of(k)) for k in used}
        return maker, morph, moving, frames, targets, moving_s

    maker, morph, moving, frames, targets, moving_s = make_frames(FrameSettings())
    seen = {k: capture(f) for k, f in frames.items()}
    psnr = lambda k: masked_psnr(seen[k], targets[k], mask)  # noqa: E731
    holds = [("hold", 0, 0.0), ("hold", 1, 0.0)] if ("hold", 1, 0.0) in frames else [("hold", 0, 0.0)]
    keyed = float(np.mean([psnr(k) for k in holds] + [psnr(moving[0])]))  # look B's keyed frame: moving at t=0
    pick = lambda keys, n: [keys[round(j * (len(keys) - 1) / (n - 1))] for j in range(n)]  # noqa: E731
    inbetween = pick(morph, 4) + pick(moving[1:], 4)
    inbetween_psnr = [psnr(k) for k in inbetween]
    flicker = {name: _flicker([seen[k] for k in keys], [targets[k] for k in keys], mask)
               for name, keys in (("morph", morph), ("moving", moving))}
    model_flicker = max(_flicker([setup.model.predict(frames[k]) for k in keys], [targets[k] for k in keys], mask)
                        for keys in (morph, moving))
    _, morph0, moving0, frames0, targets0, _ = make_frames(FrameSettings(field_steps=0))
    unadapted = max(_flicker([capture(frames0[k]) for k in keys], [targets0[k] for k in keys], mask)
                    for keys in (morph0, moving0))

    # dissolves: the crossfade of the looks' frames and the keyed dissolve against each frame compensated itself
    dissolve = FrameMaker(Show([Look(folders[0], LOOKS[0], "styletransfer", 0, hold_s=0.3),
                                Look(folders[1], LOOKS[1], "styletransfer", 0, hold_s=0.3)],
                               [Transition("dissolve", 1.0)], fps=FPS), setup)
    crossfade = FrameMaker(dissolve.show, setup, settings=FrameSettings(dissolve="crossfade"))
    mix = lambda w: ((1 - w) * image(dissolve.target_of(("hold", 0, 0.0))) ** 2.2  # noqa: E731
                     + w * image(dissolve.target_of(("hold", 1, 0.0))) ** 2.2) ** (1 / 2.2)
    own = lambda w: masked_psnr(capture(dissolve.frame(("dissolve_key", 0, 1, w))), mix(w), mask)  # noqa: E731
    out = {
        "keyed_psnr_db": keyed, "inbetween_psnr_db": inbetween_psnr,
        "inbetween_psnr_drop_db": keyed - float(np.mean(inbetween_psnr)),
        "temporal_flicker": max(flicker.values()), "temporal_flicker_morph": flicker["morph"],
        "temporal_flicker_moving": flicker["moving"], "temporal_flicker_unadapted": unadapted,
        "temporal_flicker_model": model_flicker,
        "dissolve_check_db": masked_psnr(capture(crossfade.frame(("dissolve", 0, 1, 0.5))), mix(0.5), mask) - own(0.5),
        "dissolve_keyed_between_db": masked_psnr(capture(dissolve.frame(("dissolve", 0, 1, 0.375))), mix(0.375),
                                                 mask) - own(0.375),
        "frames_per_second_moving": 1.0 / moving_s,
    }
    if sheet_path:
        from ...lapig_core.common.imageio import write_png
        from ...lapig_core.common.sheets import labelled_grid

        tiles = [(targets[holds[0]], "look 1 (target)"), (seen[holds[0]], "look 1 captured"),
                 (targets[morph[len(morph) // 2]], "morph midpoint (target)"),
                 (seen[morph[len(morph) // 2]], "morph midpoint captured"),
                 (targets[moving[6]], "drifting look (target)"), (seen[moving[6]], "drifting look captured"),
                 (frames[morph[len(morph) // 2]][0], "morph: projector 1"),
                 (frames[morph[len(morph) // 2]][1], "morph: projector 2")]
        write_png(sheet_path, labelled_grid([t for t, _ in tiles], [n for _, n in tiles], columns=4, cell=256,
                                              title="a show on two projectors (fake rig, simulated)"))
    return out


def run(args) -> dict:
    from ...lapig_core.show.joint_setup import JointShowSetup

    t0 = time.perf_counter()
    psa_iterations = int(getattr(args, "psa_iterations", None) or 10)
    working_size = 256
    rig = fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.0)
    with tempfile.TemporaryDirectory() as tmp:
        setup_dir = _capture(rig, os.path.join(tmp, "data"))
        folders = _looks(setup_dir, os.path.join(tmp, "results"), psa_iterations, working_size)
        setup = JointShowSetup.from_capture(setup_dir, working_size=working_size,
                                            gammas=[p.gamma for p in rig.projectors])
        os.makedirs(BENCHMARKS, exist_ok=True)
        figures = quality_and_speed(setup, folders, rig, os.path.join(BENCHMARKS, "bench_show_multi.png"))

    def r(x, n=3):
        if isinstance(x, list):
            return [r(v, n) for v in x]
        return None if x is None or not math.isfinite(x) else round(float(x), n)

    summary = {k: r(v) for k, v in figures.items()}
    summary.update({
        "measured_by": "simulated: tools/fakes/fake_rig side by side (8-bit, noise off), its capture and joint "
                       "first look; not Cycles",
        "camera": list(CAMERA), "projectors": [list(PROJECTOR)] * 2, "working_size": working_size,
        "psa_iterations_keyed": psa_iterations, "fps": FPS, "sheet": "benchmarks/bench_show_multi.png",
        "loadavg_1m": round(os.getloadavg()[0], 2), "bench_seconds": r(time.perf_counter() - t0, 1)})
    from .machine_figure import machine_speed, with_machine_figures

    written = with_machine_figures(summary, machine_speed())
    import json

    with open(os.path.join(BENCHMARKS, "bench_show_multi.json"), "w") as f:
        json.dump(written, f, indent=1, default=str)
    return written
