# SPDX-License-Identifier: GPL-3.0-or-later
"""Registration where Gray-code stripes blur: lit camera pixels where some bits do not read are given the
projector position their decoded neighbours suggest, among the positions the bits that did read allow.

On a rig of several projectors each one lights parts of the object at grazing incidence (the top of a bust's
shoulders from projectors at its height): many projector pixels fall into one camera pixel, the finest
stripes average to grey (and, where the pixel straddles a coarser stripe's edge, that bit too), and
``decode_graycode`` rejects the pixel although the projector plainly lights it. Left out, such pixels count
as unreached: no projector may correct them, the joint compensation leaves them as they are, coverage falls.

Gray code changes one bit per stripe edge, so the bits that still read allow a few runs of projector pixels
(``PartialCode.positions``). The neighbours' position (push-pull over the decoded pixels) picks the nearest
allowed one; the run it lies in is the doubt, and a pixel whose doubt exceeds ``2 ** MAX_UNKNOWN_BITS``
projector pixels on either axis stays unregistered, as does a pixel lit too faintly (the object's outline,
mixed with the background).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..capture.structured_light import DecodeResult, PartialCode
from .push_pull import push_pull

# At most 64 projector pixels of doubt per axis. A camera pixel whose fine stripes read grey spans about as
# much of the projector frame already, so the doubt is about the pixel's own footprint; the cap keeps out
# pixels whose bits noise has spoiled. On the bench's bust (BENCHMARKS, "Several projectors") caps of 4, 5,
# 6 and 7 bits register 0.9845, 0.9848, 0.9848 and 0.9849 of the object (the strict decode 0.9681).
MAX_UNKNOWN_BITS = 6
_CHUNK = 1024  # camera pixels per block of the (pixels x projector size) tables: ~100 MB at a 4K projector


@dataclass
class FilledDecode:
    decoded: DecodeResult  # the decode with the filled pixels valid
    filled: np.ndarray  # bool (H, W): the pixels this fill added


def fill_unread_bits(decoded: DecodeResult, partial: PartialCode, max_unknown_bits: int | None = None) -> FilledDecode:
    """``decoded`` (the strict decode) plus the lit pixels whose doubt is at most 2 ** ``max_unknown_bits``
    projector pixels per axis (None: MAX_UNKNOWN_BITS; -1 fills nothing). Decoded pixels keep their values."""
    cap = MAX_UNKNOWN_BITS if max_unknown_bits is None else max_unknown_bits
    ok = np.asarray(decoded.valid, bool) & (decoded.proj_x >= 0) & (decoded.proj_y >= 0)
    want = partial.lit & ~ok
    if cap < 0 or not want.any() or not ok.any():
        return FilledDecode(decoded, np.zeros_like(ok))
    guess = push_pull(np.stack([decoded.proj_x, decoded.proj_y], -1).astype(np.float32), ok.astype(np.float32))
    rows, cols = np.nonzero(want)
    px, run_x = _nearest_allowed(partial, "x", rows, cols, guess[rows, cols, 0])
    py, run_y = _nearest_allowed(partial, "y", rows, cols, guess[rows, cols, 1])
    keep = (run_x <= 2 ** cap) & (run_y <= 2 ** cap) & (px >= 0) & (py >= 0)
    out_x, out_y, filled = decoded.proj_x.copy(), decoded.proj_y.copy(), np.zeros_like(ok)
    out_x[rows[keep], cols[keep]] = px[keep]
    out_y[rows[keep], cols[keep]] = py[keep]
    filled[rows[keep], cols[keep]] = True
    return FilledDecode(DecodeResult(out_x.astype(np.int32), out_y.astype(np.int32), ok | filled), filled)


def _nearest_allowed(partial: PartialCode, axis: str, rows, cols, guess):
    """Per pixel: the allowed position nearest ``guess`` (-1 where none is allowed) and the length of the run
    of allowed positions it lies in."""
    best = np.full(len(rows), -1, np.int64)
    run = np.zeros(len(rows), np.int64)
    for start in range(0, len(rows), _CHUNK):
        part = slice(start, start + _CHUNK)
        allowed = partial.positions(axis, rows[part], cols[part])
        n = allowed.shape[1]
        dist = np.where(allowed, np.abs(np.arange(n)[None, :] - guess[part, None]), np.inf)
        pick = np.argmin(dist, axis=1)
        has = np.isfinite(dist[np.arange(len(pick)), pick])
        # the run around the pick: allowed positions to its left and right, counted up to the first gap
        left = np.cumsum(~allowed, axis=1)  # gaps so far, left to right
        same_run = left == left[np.arange(len(pick)), pick][:, None]
        length = (same_run & allowed).sum(axis=1)
        best[part] = np.where(has, pick, -1)
        run[part] = np.where(has, length, 0)
    return best, run
