# SPDX-License-Identifier: GPL-3.0-or-later
"""One setup's compensation and simulation modules with its reference captures: what PSA, the native
output and the benchmarks take (pipeline.surface_models builds it from a capture)."""
from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class SurfaceModels:
    """The fine-tuned networks of one setup and its reference captures (1,3,H,W)."""

    compensator: torch.nn.Module  # CompenNeSt (or the classical model where it was chosen)
    simulator: torch.nn.Module  # PCNet
    s: torch.Tensor
    i_min: torch.Tensor
    i_max: torch.Tensor
    # (1,1,H,W) the projector pixels that land on the object, or None (all): PSA's losses count only
    # those, so the frame around a statue (black in the projector image) does not steer the look
    on_object: torch.Tensor | None = None

    def __post_init__(self):
        for net in (self.compensator, self.simulator):
            net.eval()
            for p in net.parameters():
                p.requires_grad_(False)  # only theta learns
        self.compensator.cache_surface(self.s)

    @property
    def device(self) -> torch.device:
        return self.s.device

    def to(self, device) -> "SurfaceModels":
        """Move the networks and the references to `device` (None: stay), in place, and cache the surface's
        features there; returns self, so the attributes set after construction (choice, first_look) stay."""
        if device is None:
            return self
        self.compensator.to(device)
        self.simulator.to(device)
        self.s, self.i_min, self.i_max = self.s.to(device), self.i_min.to(device), self.i_max.to(device)
        self.on_object = self.on_object.to(device) if self.on_object is not None else None
        self.compensator.cache_surface(self.s)
        return self

    def compensate(self, target, return_raw=False):
        return self.compensator(target, self.s, return_raw=return_raw)

    def simulate(self, projector_image):
        return self.simulator(projector_image, self.s, self.i_min, self.i_max)
