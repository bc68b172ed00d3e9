# SPDX-License-Identifier: GPL-3.0-or-later
"""The result folder of several projectors: one image per projector, listed in result.json.

Written whole or not at all, as one projector's (export/result_files.write_new_result): 16-bit PNGs
projector_1.png .. projector_K.png (each at its projector's native size, the blend and the compensation in
it), the look and the joint model's capture of those images in camera space (look.png, predicted.png), the
surface it was made from (surface.png) and a comparison sheet. result.json's "projectors" lists each image with its projector's
name and size; "multi" holds the joint figures. With PSA (stylize_joint's default) the un-adapted look is
kept beside it, as one projector's result keeps target_nopsa: look_nopsa.png, predicted_nopsa.png and
projector_1_nopsa.png .. (result.json's "psa" says what PSA did, "metrics" both simulated PSNRs).
"""
from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np

from ..common.psnr import masked_psnr
from ..common.sheets import labelled_grid
from ..export.result_files import read_result_image, read_summary, write_new_result

MULTI_KEY = "multi"


def projector_image_name(k: int) -> str:
    """Projector k's (0-based) image in the result folder, without its .png."""
    return f"projector_{k + 1}"


def is_multi_result(folder) -> bool:
    try:
        return MULTI_KEY in read_summary(folder)
    except (OSError, ValueError):
        return False


def write_joint_result(root, name: str, look, surface: np.ndarray, names, sizes, summary: dict,
                       reached: np.ndarray) -> tuple[Path, dict]:
    """Write the folder of a JointLook (lapig_core/multi/stylize) under `root`; returns (folder, summary).
    summary: what the caller records (prompt, backend, capture, models, ...), completed here."""
    frames = look.frames
    predicted = look.shown  # the model's capture of the projector images (JointLook.simulated)
    images = {"look": look.target, "predicted": predicted, "surface": surface}
    images.update({projector_image_name(k): frame for k, frame in enumerate(frames)})
    psnr = masked_psnr(predicted, look.target, reached)  # nan where nothing is reached
    tiles = [(surface, "surface (all projectors white)"), (look.target, "look" + (" with PSA" if look.without else "")),
             (predicted, "predicted capture")]
    metrics = {"simulated_psnr": psnr}
    if getattr(look, "simulated", None) is not None:  # the drives' own figure, finer than the frames can show
        metrics["simulated_psnr_drives"] = masked_psnr(look.compensation.predicted, look.target, reached)
    without = getattr(look, "without", None)
    if without is not None:
        images.update({"look_nopsa": without.target, "predicted_nopsa": without.shown})
        images.update({f"{projector_image_name(k)}_nopsa": frame for k, frame in enumerate(without.frames)})
        metrics["simulated_psnr_nopsa"] = masked_psnr(without.shown, without.target, reached)
        tiles += [(surface, "surface"), (without.target, "look without PSA"),
                  (without.shown, "predicted without PSA")]
    tiles += [(frame, f"{names[k]}") for k, frame in enumerate(frames)]
    images["comparison"] = labelled_grid([t for t, _ in tiles], [lab for _, lab in tiles], columns=3, cell=256,
                                         title=summary.get("prompt", ""))
    understood = (look.describe.get("understood_line") or summary.get("backend", "")).partition(" | ")[0]
    psa_words = (f"PSA on their joint reach ({metrics['simulated_psnr_nopsa']:.1f} dB without)" if without is not None
                 else "no PSA")
    line = (f"{understood}; {len(frames)} projectors; simulated by the joint model {psnr:.1f} dB; the look within "
            f"their reach on {look.reach_share:.0%} of the object; {psa_words}")
    full = {**summary, "lgst": look.describe, "psa": getattr(look, "psa", None) or False,
            "notes": list(summary.get("notes", [])) + list(look.describe.get("notes", [])),
            "projectors": [{"name": n, "image": f"{projector_image_name(k)}.png", "size": list(size)}
                           for k, (n, size) in enumerate(zip(names, sizes))],
            MULTI_KEY: {**summary.get(MULTI_KEY, {}), "count": len(frames), "reach_share": look.reach_share,
                        "reach_share_nopsa": None if without is None else without.reach_share,
                        "solve_seconds": round(look.compensation.seconds, 3),
                        "lgst_seconds": round(look.lgst_seconds, 3)},
            "metrics": metrics,
            "summary_line": line,
            "created": datetime.datetime.now().isoformat(timespec="seconds")}
    return write_new_result(root, name, images, full), full


def projector_images(folder) -> list[tuple[dict, np.ndarray]]:
    """(result.json's entry, the image) of each projector of a result of several, in order."""
    summary = read_summary(folder)
    entries = summary.get("projectors") or []
    if MULTI_KEY not in summary or not entries:
        raise ValueError(f"{folder} is a result of one projector, not of several")
    return [(entry, read_result_image(folder, Path(entry["image"]).stem)) for entry in entries]
