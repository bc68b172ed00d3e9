# SPDX-License-Identifier: GPL-3.0-or-later
"""The working frame: the whole projector frame at the resolution the networks work at.

A working size setting is the frame's long side; the short side follows the projector's aspect
ratio. Both are rounded to a multiple of NETWORK_MULTIPLE: CompenNeSt and PCNet go down by two
stride-2 convolutions and back up by two transposed ones, so any side divisible by 4 comes back
at its own size (the style net needs the same; InstructPix2Pix resizes to its own multiple).
"""
from __future__ import annotations

NETWORK_MULTIPLE = 4
MIN_SIDE = 16  # the SSIM window (11 px) and two stride-2 levels need a few pixels
MAX_LONG_SIDE = 1024  # fine-tuning and PSA hold several frames of activations per image
ASPECT_TOLERANCE = 0.02  # relative: what rounding each side to a multiple of 4 changes at most


class WorkingFrameError(ValueError):
    """A working size the networks cannot use, or a data set that does not fit the projector."""


def _rounded(value: float) -> int:
    """The nearest multiple of NETWORK_MULTIPLE (halves up)."""
    return max(NETWORK_MULTIPLE, int(value / NETWORK_MULTIPLE + 0.5) * NETWORK_MULTIPLE)


def working_frame(long_side: int, proj_width: int, proj_height: int) -> tuple[int, int]:
    """(width, height) of the working frame with ``long_side`` on the projector's longer side."""
    if not MIN_SIDE <= long_side <= MAX_LONG_SIDE:
        raise WorkingFrameError(f"the working size must be {MIN_SIDE} to {MAX_LONG_SIDE} pixels, got {long_side}")
    native_long = max(proj_width, proj_height)
    if long_side > native_long:
        raise WorkingFrameError(f"the working size {long_side} is larger than the projector's "
                                f"{proj_width}x{proj_height} frame: use at most {native_long}")
    long_rounded = _rounded(long_side)
    short = _rounded(long_rounded * min(proj_width, proj_height) / native_long)
    width, height = (long_rounded, short) if proj_width >= proj_height else (short, long_rounded)
    if min(width, height) < MIN_SIDE:
        raise WorkingFrameError(
            f"at working size {long_side} the {proj_width}x{proj_height} frame is {width}x{height}: its short "
            f"side needs at least {MIN_SIDE} pixels; raise the working size")
    return width, height


def aspect_text(width: int, height: int) -> str:
    return f"{width}x{height} (aspect {width / height:.3f})"


def check_aspect(frame: tuple[int, int], projector: tuple[int, int], what: str = "the capture",
                 advice: str = "") -> None:
    """WorkingFrameError unless a working frame (width, height) has the projector's aspect ratio;
    ``advice`` ends the message (what to do about it)."""
    (w, h), (pw, ph) = frame, projector
    if abs((w / h) / (pw / ph) - 1.0) > ASPECT_TOLERANCE:
        raise WorkingFrameError(f"{what} is {aspect_text(w, h)} but the projector is {aspect_text(pw, ph)}: "
                                f"it cannot cover the projector's frame" + (f"; {advice}" if advice else ""))
