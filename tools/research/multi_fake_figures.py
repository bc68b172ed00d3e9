# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors on the numpy fake rig (issue 36): PSA on the joint reach (a stack of two against one, PSA
against none) and the refinement of all projectors together against the open loop, with a sheet to look at.

    .venv/bin/python tools/research/multi_fake_figures.py [--sheet /tmp/multi_psa_refine.png]

Prints one JSON object: `stack_psa_gain_db` (tools/bench/stack_gain.stack_psa_gain) per prompt and surface,
`refine_gain_db_multi` (lapig_core/refine/joint.refine_gain_db_multi) per rig. The Cycles-rendered figures are
`bench multi`'s; these need no Blender and run in seconds.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _lapig():
    """The repository root as the package `lapig`, as Blender and the tests load it."""
    if "lapig" not in sys.modules:
        spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py",
                                                      submodule_search_locations=[str(ROOT)])
        package = importlib.util.module_from_spec(spec)
        sys.modules["lapig"] = package
        spec.loader.exec_module(package)
    return sys.modules["lapig"]


PROMPTS = ("Make it a stained glass artwork", "a warm watercolor sunset", "Van Gogh starry night")


def _white(rig):
    return rig.capture([np.ones(p.size[::-1] + (3,), np.float32) for p in rig.projectors]).astype(np.float32) / 255


def _perturbed_fit(rig, make):
    """A joint model fitted on the rig as it is not (other gains and gammas): the model error refinement corrects."""
    from lapig.tools.fakes import fake_rig
    from lapig.lapig_core.multi.joint_model import JointModel

    wrong = make()
    for p, gain, gamma in zip(wrong.projectors, (1.2, 0.85, 1.1), (0.2, -0.15, 0.1)):
        p.gain *= gain
        p.gamma += gamma
    shown = [fake_rig.smooth_frames(p.size, 16, seed=10 + k) for k, p in enumerate(wrong.projectors)]
    captures, black = wrong.capture_alone(shown)
    return JointModel.fit([wrong.camera_map(k) for k in range(wrong.count)], shown, captures, black)


def run(sheet_path: str | None) -> dict:
    _lapig()
    import cv2

    from lapig.lapig_core.common.imageio import write_png
    from lapig.lapig_core.common.psnr import masked_psnr
    from lapig.lapig_core.common.sheets import labelled_grid
    from lapig.tools.fakes import fake_rig
    from lapig.tools.bench.stack_gain import stack_psa_gain
    from lapig.lapig_core.multi.joint_solve import reach
    from lapig.lapig_core.refine.joint import refine_gain_db_multi

    camera, projector = (96, 72), (192, 144)
    out = {"camera": camera, "projector": projector, "psa": {}, "refine": {}}
    tiles = []
    from lapig.lapig_core.psa.adaptation import PSASettings

    for scale, adaptation in ((0.3, 0.5), (0.3, 0.0), (0.2, 0.5)):
        for prompt in PROMPTS:
            rig = fake_rig.stacked_rig(2, camera, projector, albedo_scale=scale)
            one = rig.subset([0])
            looks = {}
            fig = stack_psa_gain(rig.true_model(), one.true_model(), _white(rig), prompt, working_size=256,
                                 object_mask=rig.object_mask, single_surface=_white(one), looks=looks,
                                 settings=PSASettings(adaptation=adaptation))
            out["psa"][f"albedo x{scale} / adaptation {adaptation} / {prompt}"] = fig.to_dict()
            if scale == 0.3 and adaptation == 0.5 and prompt == PROMPTS[0]:
                for name, model in (("2 stacked", rig.true_model()), ("1", one.true_model())):
                    look = looks["stacked" if name == "2 stacked" else "single"]
                    tiles += [(look.without.target, f"{name}: look, no PSA"),
                              (model.predict(look.without.frames), f"{name}: sim., no PSA"),
                              (look.target, f"{name}: look, PSA"),
                              (model.predict(look.frames), f"{name}: sim., PSA")]
                    tiles += [(cv2.resize(f, camera, interpolation=cv2.INTER_AREA), f"{name}: proj. {k + 1}")
                              for k, f in enumerate(look.frames)]
                    if len(look.frames) == 1:
                        tiles.append((np.zeros_like(look.target), ""))
                stacked_look, stacked_rig = looks["stacked"], rig
    for adaptation in (0.5, 0.0):
        rows = [v for k, v in out["psa"].items() if f"adaptation {adaptation} /" in k]
        out[f"adaptation {adaptation}"] = {m + "_mean": round(float(np.mean([r[m] for r in rows])), 3) for m in (
            "stack_psa_gain_db", "stack_look_gain_db", "psa_gain_db_stacked", "psa_gain_db_single")}

    rigs = {"side by side": lambda: fake_rig.side_by_side_rig(camera, projector, noise=0.002),
            "three": lambda: fake_rig.three_projector_rig(camera, projector, noise=0.002),
            "stacked dark": lambda: fake_rig.stacked_rig(2, camera, projector, noise=0.002)}
    for name, make in rigs.items():
        true = make()
        model = _perturbed_fit(true, make)
        if name == "stacked dark":  # the PSA look of the sheet, refined on the true rig
            target = stacked_look.target
        else:
            lo, hi = reach(model)
            pattern = cv2.resize(np.random.default_rng(5).random((6, 8, 3)).astype(np.float32), camera,
                                 interpolation=cv2.INTER_CUBIC).clip(0, 1)
            target = lo + (hi - lo) * (0.1 + 0.8 * pattern)
        record, refinement = refine_gain_db_multi(model, fake_rig.FakeRigDevice(true), target, true.object_mask)
        d = record.to_dict()
        out["refine"][name] = {"refine_gain_db_multi": d["gain_db"], **{k: d[k] for k in (
            "open_loop_psnr", "refined_psnr", "noise_floor_psnr", "iterations", "captures", "stopped", "history")}}
        if name == "stacked dark":
            from lapig.lapig_core.multi.joint_solve import joint_compensate

            open_frames = joint_compensate(model, target).frames
            open_cap = true.capture(open_frames).astype(np.float32) / 255
            refined_cap = true.capture(refinement.images).astype(np.float32) / 255
            m = refinement.valid
            tiles += [(refinement.target, "PSA look in reach"),
                      (open_cap, f"open loop {masked_psnr(open_cap, refinement.target, m):.1f} dB"),
                      (refined_cap, f"refined {masked_psnr(refined_cap, refinement.target, m):.1f} dB"),
                      (np.clip(np.abs(open_cap - refinement.target) * 4, 0, 1), "open error x4"),
                      (np.clip(np.abs(refined_cap - refinement.target) * 4, 0, 1), "refined error x4"),
                      (cv2.resize(refinement.images[0], camera, interpolation=cv2.INTER_AREA), "refined proj. 1")]
    out["refine_gain_db_multi_mean"] = round(float(np.mean([v["refine_gain_db_multi"]
                                                            for v in out["refine"].values()])), 3)
    if sheet_path:
        write_png(sheet_path, labelled_grid([t for t, _ in tiles], [lab for _, lab in tiles], columns=6, cell=256,
                                            title="fake rig, dark stack: 2 projectors vs 1, PSA; refined on the rig"))
        out["sheet"] = sheet_path
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sheet", default="/tmp/multi_psa_refine.png")
    args = parser.parse_args(argv)
    print(json.dumps(run(args.sheet), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
