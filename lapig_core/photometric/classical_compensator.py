# SPDX-License-Identifier: GPL-3.0-or-later
"""The classical per-pixel compensation (classical.ClassicalModel) as a torch module, where Train chose it.

Apart from classical.py, which stays numpy only: the model is the fallback that needs no torch.
"""
from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from .choice import CLASSICAL
from .classical import ClassicalModel


class ClassicalCompensator(torch.nn.Module):
    """The classical per-pixel compensation as a differentiable module with CompenNeSt's call
    signature, so PSA and the native output use it where it was chosen.

    Its per-pixel pseudo-inverse and offset live at the working frame; another size (the native
    output) resamples them bilinearly (`frame_inputs` gives them to the tiling as extra inputs)."""

    ARCH_NAME = CLASSICAL

    def __init__(self, model: ClassicalModel):
        super().__init__()
        pinv = model.pseudo_inverse()  # (H, W, 3, 3)
        h, w = pinv.shape[:2]
        self.register_buffer("pinv", torch.from_numpy(np.ascontiguousarray(pinv.reshape(h, w, 9))).permute(2, 0, 1)[None])
        self.register_buffer("offset", torch.from_numpy(np.ascontiguousarray(model.o)).permute(2, 0, 1)[None].float())
        self.gamma_c, self.gamma_p = float(model.gamma_c), float(model.gamma_p)

    def cache_surface(self, s):  # CompenNeSt caches its surface features; nothing to cache here
        pass

    def frame_inputs(self, height: int, width: int) -> list[torch.Tensor]:
        """The per-pixel parameters at height x width."""
        if (height, width) == tuple(self.pinv.shape[-2:]):
            return [self.pinv, self.offset]
        size = (height, width)
        return [F.interpolate(self.pinv, size, mode="bilinear", align_corners=False),
                F.interpolate(self.offset, size, mode="bilinear", align_corners=False)]

    def forward(self, target, s=None, pinv=None, offset=None, return_raw=False):
        if pinv is None:
            pinv, offset = self.frame_inputs(*target.shape[-2:])
        pinv = pinv.to(target.dtype)
        rhs = target.clamp(0, 1) ** self.gamma_c - offset.to(target.dtype)
        n, _, h, w = target.shape
        x = (pinv.reshape(pinv.shape[0], 3, 3, h, w) * rhs[:, None]).sum(2)  # per pixel M^+ (t^gc - o)
        out = x.clamp(1e-6, 1.0) ** (1.0 / self.gamma_p)
        if not return_raw:
            return out
        raw = torch.sign(x) * x.abs().clamp_min(1e-6) ** (1.0 / self.gamma_p)  # > 1 where it would saturate
        return out, raw


class ClassicalSimulator(torch.nn.Module):
    """The classical model's forward direction as a differentiable module with PCNet's call signature: the
    simulator PSA runs its losses through for a first look (a capture whose networks are not trained yet).

    C = (M f_p(P) + o) ** (1 / gamma_c), f_p(P) = P ** gamma_p, per pixel (classical.ClassicalModel.simulate),
    then within the capture bounds [i_min, i_max] where given, as PCNet's output is."""

    ARCH_NAME = CLASSICAL

    def __init__(self, model: ClassicalModel):
        super().__init__()
        h, w = model.shape
        m = np.ascontiguousarray(model.M)  # (H, W, 3, 3), rows: camera channels
        self.register_buffer("m", torch.from_numpy(m).permute(2, 3, 0, 1)[None].float())  # (1, 3, 3, H, W)
        self.register_buffer("offset", torch.from_numpy(np.ascontiguousarray(model.o)).permute(2, 0, 1)[None].float())
        self.gamma_c, self.gamma_p = float(model.gamma_c), float(model.gamma_p)

    def forward(self, x, s=None, i_min=None, i_max=None):
        if tuple(x.shape[-2:]) != tuple(self.m.shape[-2:]):
            raise ValueError(f"the classical simulator is {self.m.shape[-2]}x{self.m.shape[-1]}, "
                             f"the projector image {x.shape[-2]}x{x.shape[-1]}")
        # clamp_min: the gradient of P ** gamma_p and of L ** (1/gamma_c) is unbounded at 0
        light = x.clamp(1e-6, 1.0) ** self.gamma_p
        linear = (self.m.to(x.dtype) * light[:, None]).sum(2) + self.offset.to(x.dtype)
        y = linear.clamp(1e-6, 1.0) ** (1.0 / self.gamma_c)
        if i_min is not None:
            y = torch.maximum(y, torch.as_tensor(i_min, dtype=y.dtype))
        if i_max is not None:
            y = torch.minimum(y, torch.as_tensor(i_max, dtype=y.dtype))
        return y
