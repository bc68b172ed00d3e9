# SPDX-License-Identifier: GPL-3.0-or-later
"""The surface references (I-, I+, s) registered again at another size, up to the projector's native one.

The data set keeps the raw camera captures of the references and registration.npz keeps the dense
projector -> camera map, so the references can be pulled into any frame size without capturing
again: what native-resolution output compensates with.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..common.imageio import ImageReadError, read_image
from . import dataset as ds
from .registration import Registration


@dataclass
class References:
    """Float32 (H, W, 3) captures under black, white and gray projection, and where they are valid."""

    black: np.ndarray  # I-
    white: np.ndarray  # I+
    gray: np.ndarray  # s
    valid: np.ndarray  # (H, W) bool: the projector pixels the camera sees

    @property
    def frame_size(self) -> tuple[int, int]:
        return self.valid.shape[1], self.valid.shape[0]


def registered_references(setup_dir, width: int, height: int) -> References:
    """The setup's raw references registered into a width x height frame (DatasetError when a file is
    missing or unreadable)."""
    setup_dir = Path(setup_dir)
    layout = ds.DatasetLayout.of_setup_dir(setup_dir)
    path = setup_dir / ds.REGISTRATION_FILE
    if not path.is_file():
        raise ds.DatasetError(f"{setup_dir} has no {ds.REGISTRATION_FILE}: its references cannot be registered "
                              "at another size (a data set captured elsewhere)")
    registration = Registration.load(path).resized(width, height)
    images = []
    for index in (ds.REF_BLACK, ds.REF_WHITE, ds.REF_GRAY):
        try:
            raw = read_image(layout.image_path(layout.cam_raw_dir("ref"), index))
        except ImageReadError as exc:
            raise ds.DatasetError(str(exc)) from exc
        images.append(registration.warp(raw, return_valid=True))
    valid = images[0][1] & images[1][1] & images[2][1]
    return References(images[0][0], images[1][0], images[2][0], valid)
