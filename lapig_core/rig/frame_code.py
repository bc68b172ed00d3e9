# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame code: a few cells at the top and bottom edges of every shown frame that say which frame it is.

A real camera returns what its buffer holds, which may be the previous pattern (stale), a black or
empty image (dropped), or the top of one pattern and the bottom of another (torn: the projector or a
rolling shutter updated half-way). So each frame the rig shows carries its sequence number in two
bands, one at the top and one at the bottom of the projector frame, and every grabbed image is read
back before it is kept: both bands must read the number just shown.

Each band holds CODE_BITS bits of the sequence number, each bit as a pair of cells (the bit, then its
complement): a bit reads as the brighter of its two cells, so the code needs no threshold and holds on
any albedo or ambient light the two cells share. Sequence numbers wrap at 2**CODE_BITS; a stale frame
is one behind, so 4 bits are plenty.

The bands overwrite the frame's top and bottom rows during a capture: the capture sequence marks those
rows invalid (CaptureDevice.reserved_rows), as it does for the parts the camera does not see.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CODE_BITS = 4
CELLS_PER_BAND = 2 * CODE_BITS
BANDS = ("top", "bottom")


def band_height(height: int, share: float = 0.04, minimum: int = 6) -> int:
    """Rows of each band in a frame of ``height`` rows."""
    return max(minimum, int(round(share * height)))


@dataclass(frozen=True)
class CodeLayout:
    """Where the cells are in a (width, height) projector frame."""
    width: int
    height: int
    band: int  # rows per band

    @classmethod
    def for_frame(cls, width: int, height: int, share: float = 0.04) -> "CodeLayout":
        return cls(width, height, band_height(height, share))

    def cell_box(self, band: int, cell: int) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1) of cell ``cell`` (0..CELLS_PER_BAND-1) of band 0 (top) or 1 (bottom)."""
        edges = np.linspace(0, self.width, CELLS_PER_BAND + 1).round().astype(int)
        y0 = 0 if band == 0 else self.height - self.band
        return int(edges[cell]), y0, int(edges[cell + 1]), y0 + self.band

    def cells(self):
        """Every (band, cell) pair, in a fixed order."""
        return [(b, c) for b in range(len(BANDS)) for c in range(CELLS_PER_BAND)]

    def reserved_rows(self) -> tuple[int, int]:
        """(rows at the top, rows at the bottom) the code takes from every frame."""
        return self.band, self.band


def cell_values(number: int) -> list[bool]:
    """The lit state of a band's cells for a sequence number: per bit (most significant first), the bit
    then its complement."""
    states = []
    for k in reversed(range(CODE_BITS)):
        bit = bool((number >> k) & 1)
        states += [bit, not bit]
    return states


def stamp(frame: np.ndarray, layout: CodeLayout, number: int) -> np.ndarray:
    """A copy of ``frame`` (H, W, 3) with the code of ``number`` in both bands (full white / black)."""
    out = np.array(frame, copy=True)
    white = np.iinfo(out.dtype).max if out.dtype.kind in "ui" else 1.0
    for band in range(len(BANDS)):
        for cell, lit in enumerate(cell_values(number)):
            x0, y0, x1, y1 = layout.cell_box(band, cell)
            out[y0:y1, x0:x1] = white if lit else 0
    return out


def single_cell(layout: CodeLayout, band: int, cell: int, dtype=np.uint8) -> np.ndarray:
    """A black frame with one cell white: what the rig shows to find that cell in the camera."""
    frame = np.zeros((layout.height, layout.width, 3), dtype)
    x0, y0, x1, y1 = layout.cell_box(band, cell)
    frame[y0:y1, x0:x1] = np.iinfo(dtype).max
    return frame


@dataclass
class CellMap:
    """Where the camera sees each cell: a boolean camera mask per (band, cell), and the contrast (lit minus
    unlit, in camera levels 0..1) it showed when it was found."""
    masks: dict  # (band, cell) -> (Hc, Wc) bool
    contrast: dict  # (band, cell) -> float

    def readable_bands(self) -> list[int]:
        """Bands whose every cell the camera sees."""
        return [b for b in range(len(BANDS))
                if all((b, c) in self.masks for c in range(CELLS_PER_BAND))]


def locate_cells(black: np.ndarray, lit: dict, min_contrast: float = 0.08, min_pixels: int = 4) -> CellMap:
    """The camera mask of each cell from a capture of a black frame and one of each cell lit alone
    (``lit``: (band, cell) -> camera image). A cell the camera does not see (its brightest change
    below ``min_contrast``, or fewer than ``min_pixels`` pixels) has no mask."""
    base = luma(black)
    masks, contrast = {}, {}
    for key, image in lit.items():
        diff = luma(image) - base
        peak = float(np.percentile(diff, 99.9))
        if peak < min_contrast:
            continue
        mask = diff > 0.5 * peak
        if mask.sum() < min_pixels:
            continue
        masks[key], contrast[key] = mask, float(diff[mask].mean())
    # a pixel lit by two cells (blur across a cell edge) belongs to neither: it would read both
    keys = list(masks)
    for i, a in enumerate(keys):
        for b in keys[i + 1:]:
            both = masks[a] & masks[b]
            if both.any():
                masks[a] = masks[a] & ~both
                masks[b] = masks[b] & ~both
    return CellMap({k: m for k, m in masks.items() if m.sum() >= min_pixels},
                   {k: contrast[k] for k, m in masks.items() if m.sum() >= min_pixels})


@dataclass(frozen=True)
class CodeReading:
    numbers: dict  # band -> number read, or None where the band was unreadable
    margin: float  # the weakest bit's difference between its two cells, as a share of their contrast

    def verdict(self, expected: int, min_margin: float = 0.25) -> str:
        """'ok', 'stale' (both bands read an earlier frame), 'torn' (the bands disagree) or 'unreadable'
        (a black, empty or washed-out frame)."""
        read = [n for n in self.numbers.values() if n is not None]
        if not read or self.margin < min_margin:
            return "unreadable"
        if len(set(read)) > 1:
            return "torn"
        return "ok" if read[0] == expected % (1 << CODE_BITS) else "stale"


def read_code(image: np.ndarray, cells: CellMap) -> CodeReading:
    """The sequence number each readable band of a camera image shows."""
    levels = luma(image)
    numbers, margins = {}, []
    for band in cells.readable_bands():
        number = 0
        for k in range(CODE_BITS):
            a, b = (band, 2 * k), (band, 2 * k + 1)
            va, vb = float(levels[cells.masks[a]].mean()), float(levels[cells.masks[b]].mean())
            scale = max(min(cells.contrast[a], cells.contrast[b]), 1e-6)
            margins.append(abs(va - vb) / scale)
            number = (number << 1) | int(va > vb)
        numbers[BANDS[band]] = number
    return CodeReading(numbers, min(margins) if margins else 0.0)


def luma(image: np.ndarray) -> np.ndarray:
    """Camera levels 0..1, one channel."""
    x = np.asarray(image)
    scale = float(np.iinfo(x.dtype).max) if x.dtype.kind in "ui" else 1.0
    x = x.astype(np.float32) / scale
    return x.mean(-1) if x.ndim == 3 else x
