# SPDX-License-Identifier: GPL-3.0-or-later
"""A dissolve's compensated keys between two stored looks (the add-on's holds and dissolves of the results'
own images, where the frames must be exactly what Export writes of each look).

The crossfade of two compensated looks misses what the surface can show of their mix (frames.py's docstring:
4.7 dB at a rendered dissolve's midpoint). The keys are the looks' targets mixed in linear light and
compensated by the capture's compensator at the output size, at DISSOLVE_KEYS; a dissolve frame is then the
linear-light crossfade of the nearest keys on either side, the looks' own projector images at its ends.
"""
from __future__ import annotations

import numpy as np
import torch

from ..native_output import compensate_frame, device_tile
from .frames import ShowSetup, key_span  # noqa: F401 (key_span: the add-on's stored dissolves ask it here)
from .morph import mix_linear


class StoredDissolve:
    """The compensated keys of dissolves at one output size, from a capture's setup (ShowSetup.from_capture).
    A setup of several projectors (joint_setup.JointShowSetup) works at the camera's size, with the looks' targets
    in camera space (their look.png), and its keys are one frame per projector (the joint solve)."""

    def __init__(self, setup: ShowSetup, width: int, height: int):
        from ..photometric.training_data import to_tensor

        self.models = setup.models
        self.project = getattr(setup, "project", None)
        refs = setup.references(width, height)
        device = self.models.device
        self.s = to_tensor(refs.gray).to(device)
        self.valid = (torch.from_numpy(refs.valid)[None, None].to(device=device, dtype=torch.float32)
                      if setup.dark_outside else None)
        self.tile = device_tile(width, height, device)
        self.size = (width, height)

    def _tensor(self, image: np.ndarray) -> torch.Tensor:
        if tuple(image.shape[:2]) != (self.size[1], self.size[0]):
            raise ValueError(f"a look's target is {image.shape[1]}x{image.shape[0]}, the output "
                             f"{self.size[0]}x{self.size[1]}")
        return torch.from_numpy(np.ascontiguousarray(image, np.float32)).permute(2, 0, 1)[None].to(self.models.device)

    def key(self, target_a: np.ndarray, target_b: np.ndarray, w: float):
        """The projector frame (H, W, 3) float32 of the two targets (H, W, 3 in [0, 1], at the output size)
        mixed in linear light at weight w and compensated; for several projectors, the list of their frames."""
        with torch.no_grad():
            target = mix_linear(self._tensor(target_a), self._tensor(target_b), float(w))
            if self.project is not None:
                return self.project(target[0].permute(1, 2, 0).clamp(0, 1).cpu().numpy().astype(np.float32))
            projector = compensate_frame(self.models.compensator, target, self.s, self.tile)
            if self.valid is not None:
                projector = projector * self.valid
        return projector[0].permute(1, 2, 0).clamp(0, 1).cpu().numpy().astype(np.float32)
