"""The look limited to the light dose, as a result of its own: a copy of the result whose projector image
is the capped frame, so Export, the preview and the projector show the limited look; the free one stays.

No bpy. The capped frame comes from light_report.capped_frame (at the projector's native size); its
cost in PSNR is measured by projecting both frames on the rig (services/projection) against the free
look's target, as Render Real Capture measures a result."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from ...lapig_core.common.imageio import read_image
from ...lapig_core.common.resample import resize_image
from ...lapig_core.common.scratch import ScratchFolder
from ...lapig_core.export.result_files import output_name, read_output_image, read_summary, write_result
from ...lapig_core.common.psnr import masked_psnr
from .light_report import REPORT_FILE
from .projection import project_and_capture

SUFFIX = "_dose_cap"


def write_capped_result(folder, capped: np.ndarray, cap_info: dict) -> Path:
    """<folder>_dose_cap (or _2, ...): the result with its output projector image replaced by `capped`
    (native H x W x 3 in [0, 1]), written whole or not at all."""
    folder = Path(folder)
    name = output_name(folder, "projector")
    h, w = read_image(folder / f"{name}.png").shape[:2]
    if capped.shape[:2] != (h, w):
        raise ValueError(f"the result's projector image is {w}x{h}, not the projector's native frame "
                         f"{capped.shape[1]}x{capped.shape[0]}: generate it at the native size (Output size 0) "
                         "to limit it")
    summary = read_summary(folder)
    summary["dose_cap"] = {**cap_info, "capped_from": str(folder)}
    scratch = ScratchFolder(folder.parent, ".writing_")
    try:
        for entry in folder.iterdir():
            if entry.is_file() and entry.name not in ("result.json", REPORT_FILE, f"{name}.png", "comparison.png"):
                shutil.copy2(entry, scratch.path / entry.name)
        write_result(scratch.path, {name: np.clip(capped, 0, 1)}, summary)
    except BaseException:
        scratch.remove()
        raise
    return scratch.move_to_new_folder(folder.name + SUFFIX)


def rendered_psnr_cost(devices, capture_dir, folder, frame: np.ndarray, capped: np.ndarray) -> dict:
    """Both frames projected and captured on the rig, each against the free look's target (dB)."""
    captured, _ = project_and_capture(devices, os.fspath(capture_dir), [frame, capped], chunk=2)
    target = resize_image(read_output_image(folder, "target"), captured.shape[2], captured.shape[1])
    whole = np.ones(target.shape[:2], bool)  # numpy PSNR over the frame: Light Report needs no torch
    free, limited = (masked_psnr(c, target, whole) for c in captured)
    return {"psnr_free_db": round(free, 3), "psnr_capped_db": round(limited, 3),
            "psnr_cost_db": round(free - limited, 3)}
