# SPDX-License-Identifier: GPL-3.0-or-later
"""Does the rig still look as it did at its capture? Checked on the refinement's first capture.

Refinement registers every capture with the capture's registration and steps through the capture's
model. If the object moved, the camera was bumped or the room's light changed, both are wrong and the
loop would "correct" the projector image towards a misaligned target. The first capture is compared
with the classical model's prediction of it:
- shifted by a few camera pixels, the prediction matches the capture better than in place: the object
  (or the camera) moved;
- in place, the capture is far from the prediction: the surface or the light changed.
"""
from __future__ import annotations

import numpy as np

from ..common.psnr import masked_psnr

SHIFT_PX = 2  # largest shift tried, in working-frame pixels
SHIFT_LEAD_DB = 1.0  # a shift must match this much better than in place to mean a move
MIN_AGREEMENT_DB = 18.0  # capture against prediction, in place: below this the rig is not the captured one


class RegistrationCheckError(ValueError):
    """The captures no longer line up with the capture the models were fitted on."""


def _shifted(img, dy, dx, image_axes=(-3, -2)):
    return np.roll(img, (dy, dx), axis=image_axes)


def registration_problem(captured, predicted, valid) -> str:
    """'' when the captures line up with the model's prediction, else the sentence to show.
    captured, predicted: (N,H,W,3) in [0,1]; valid (H,W) the pixels compared."""
    captured = np.asarray(captured, np.float64)
    predicted = np.asarray(predicted, np.float64)
    inner = np.asarray(valid, bool).copy()  # pixels whose shifted neighbours are on the object too
    for dy in range(-SHIFT_PX, SHIFT_PX + 1):
        for dx in range(-SHIFT_PX, SHIFT_PX + 1):
            inner &= _shifted(valid, dy, dx, (0, 1))
    inner[:SHIFT_PX] = inner[-SHIFT_PX:] = False
    inner[:, :SHIFT_PX] = inner[:, -SHIFT_PX:] = False
    if inner.sum() < 64:
        inner = np.asarray(valid, bool)  # a sliver of an object: check in place only
        shifts = [(0, 0)]
    else:
        shifts = [(dy, dx) for dy in range(-SHIFT_PX, SHIFT_PX + 1) for dx in range(-SHIFT_PX, SHIFT_PX + 1)]
    scores = {s: masked_psnr(captured, _shifted(predicted, *s), inner) for s in shifts}
    here = scores[(0, 0)]
    best = max(scores, key=scores.get)
    if best != (0, 0) and scores[best] > here + SHIFT_LEAD_DB:
        return (f"the object or the camera moved since the capture (the captures line up {best[1]:+d}, {best[0]:+d} "
                f"pixels off the registration): capture again before refining")
    if here < MIN_AGREEMENT_DB:
        return (f"the rig no longer looks as it did at its capture (its captures are {here:.1f} dB from the model's "
                f"prediction): capture again before refining")
    return ""
