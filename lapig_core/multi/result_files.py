# SPDX-License-Identifier: GPL-3.0-or-later
"""The result folder of several projectors: one image per projector, listed in result.json.

Written whole or not at all, as one projector's (export/result_files.write_new_result): 16-bit PNGs
projector_1.png .. projector_K.png (each at its projector's native size, the blend and the compensation in
it), the look and the joint model's capture of those images in camera space (look.png, predicted.png), the
surface it was made from (surface.png) and a comparison sheet. result.json's "projectors" lists each image with its projector's
name and size; "multi" holds the joint figures. With PSA (stylize_joint's default) the un-adapted look is
kept beside it, as one projector's result keeps target_nopsa: look_nopsa.png, predicted_nopsa.png and
projector_1_nopsa.png .. (result.json's "psa" says what PSA did, "metrics" both simulated PSNRs), and PSA's
state (theta and the tone field) as look_state.npz, which a show's morphs and motions start from.
"""
from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np

from ..common.psnr import masked_psnr
from ..common.sheets import labelled_grid
from ..export.result_files import (heat_overlay, read_result_image, read_summary,
                                   write_new_result, write_result)

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
    state, files = getattr(look, "state", None), {}
    if state:  # a look made by PSA: torch is loaded
        from ..show.look_state import look_state_files

        files = look_state_files(state)
    return write_new_result(root, name, images, full, files), full


def projector_images(folder) -> list[tuple[dict, np.ndarray]]:
    """(result.json's entry, the image) of each projector of a result of several, in order."""
    summary = read_summary(folder)
    entries = summary.get("projectors") or []
    if MULTI_KEY not in summary or not entries:
        raise ValueError(f"{folder} is a result of one projector, not of several")
    return [(entry, read_result_image(folder, Path(entry["image"]).stem)) for entry in entries]


# an error of 5 % of full scale is where the heat starts to show whole: a result that misses by less shows its
# worst places faint, not painted red by a scale that only ever follows its own 99th percentile
PROBLEM_FLOOR = 0.05


def problem_areas(folder) -> np.ndarray:
    """Where the projectors together cannot show the look, in camera space: the joint model's capture's shortfall
    from the look (mean abs over colours, what the box-constrained joint solve could not reach: light out of
    every projector's range, or a place no projector reaches) as a heat map over the surface, as one projector's
    compensability.png is over its L_ps + L_cs. Made from the result's own images; nothing is written."""
    look, predicted = read_result_image(folder, "look"), read_result_image(folder, "predicted")
    shortfall = np.abs(predicted[..., :3] - look[..., :3]).mean(axis=-1)
    scale = max(float(np.percentile(shortfall, 99)), PROBLEM_FLOOR)
    return heat_overlay(read_result_image(folder, "surface"), shortfall, scale)


def nopsa_images(folder) -> list[np.ndarray] | None:
    """Each projector's image without PSA (projector_1_nopsa.png ..), or None where the result has none."""
    summary = read_summary(folder)
    names = [f"{projector_image_name(k)}_nopsa" for k in range(len(summary.get("projectors") or []))]
    if not names or not all((Path(folder) / f"{n}.png").is_file() for n in names + ["look_nopsa"]):
        return None
    return [read_result_image(folder, n) for n in names]


def rendered_metrics(rendered: dict, folder, valid: np.ndarray) -> dict:
    """The rendered captures' figures, in camera space on `valid` (the object where some projector reaches):
    rendered_psnr against the look (as one projector's rendered_psnr is against its target) and
    rendered_vs_predicted_psnr against the joint model's predicted capture (how well the model foresaw the
    render); the same with _nopsa for the look without PSA. rendered: {"rendered": .., "rendered_nopsa": ..}."""
    out = {}
    for name, image in rendered.items():
        suffix = name[len("rendered"):]
        out["rendered_psnr" + suffix] = masked_psnr(image, read_result_image(folder, "look" + suffix), valid)
        out["rendered_vs_predicted_psnr" + suffix] = masked_psnr(image, read_result_image(folder, "predicted" + suffix),
                                                                 valid)
    return out


def write_rendered(folder, rendered: dict, summary: dict) -> Path:
    """Add Render Real Capture's images (rendered.png, rendered_nopsa.png) to a result of several, rebuild its
    comparison sheet with them (look, predicted and rendered side by side), then result.json last: `summary`
    with its metrics already updated. Written in place, each file whole (export/result_files.write_result)."""
    return write_result(folder, rendered, summary, sheet=_rendered_sheet)


def _rendered_sheet(folder: Path, rendered: dict, summary: dict) -> tuple[list, int]:
    """The sheet of a rendered result of several: look, predicted and rendered (with PSA, then without where
    made), then each projector's image; the rendered ones from memory, the others read back."""
    present = {p.stem for p in folder.glob("*.png")}
    rows = [("look", "look" + (" with PSA" if "look_nopsa" in present else "")),
            ("predicted", "predicted capture"), ("rendered", "rendered in Cycles")]
    if "rendered_nopsa" in present:
        rows += [("look_nopsa", "look without PSA"), ("predicted_nopsa", "predicted without PSA"),
                 ("rendered_nopsa", "rendered without PSA")]
    read = lambda n: rendered[n] if n in rendered else read_result_image(folder, n)  # noqa: E731
    tiles = [(read(n), lab) for n, lab in rows if n in present]
    return tiles + [(read(Path(p["image"]).stem), p["name"]) for p in summary.get("projectors") or []], 3
