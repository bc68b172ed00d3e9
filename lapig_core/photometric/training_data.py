"""Training pairs for the photometric models, built from registered capture sets.

Roles (which way a network maps, NOTES section 2):
  compensation  CompenNeSt:           (capture, s) -> projector image   (the inverse mapping)
  simulation    PCNet / CompenNeSt reversed: (projector image, s) -> capture
Every sample keeps the index of its setup, so pretraining can mix setups with their own s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..capture.dataset import CaptureSet

ROLES = ("compensation", "simulation")


def to_tensor(images: np.ndarray) -> torch.Tensor:
    """(N,H,W,3) or (H,W,3) float numpy in [0,1] -> (N,3,H,W) float32 tensor."""
    a = np.asarray(images, dtype=np.float32)
    if a.ndim == 3:
        a = a[None]
    return torch.from_numpy(np.ascontiguousarray(a.transpose(0, 3, 1, 2)))


def to_numpy(t: torch.Tensor) -> np.ndarray:
    """(N,3,H,W) or (3,H,W) tensor -> channel-last float32 numpy."""
    a = t.detach().cpu().float().numpy()
    return a.transpose(0, 2, 3, 1) if a.ndim == 4 else a.transpose(1, 2, 0)


@dataclass
class SurfaceTensors:
    """One setup's reference captures as (1,3,H,W) tensors."""

    s: torch.Tensor  # gray-lit surface
    i_min: torch.Tensor  # I-: black projection
    i_max: torch.Tensor  # I+: white projection

    @classmethod
    def from_capture_set(cls, cs: CaptureSet) -> "SurfaceTensors":
        return cls(to_tensor(cs.cam_gray), to_tensor(cs.cam_black), to_tensor(cs.cam_white))

    def to(self, device) -> "SurfaceTensors":
        return SurfaceTensors(self.s.to(device), self.i_min.to(device), self.i_max.to(device))


@dataclass
class PairSet:
    """Inputs x, targets y and setup index per sample, plus each setup's surface tensors."""

    x: torch.Tensor  # (N,3,H,W)
    y: torch.Tensor  # (N,3,H,W)
    setup_index: torch.Tensor  # (N,) long
    surfaces: list  # [SurfaceTensors]
    role: str

    def __len__(self):
        return len(self.x)

    def s_for(self, idx: torch.Tensor) -> torch.Tensor:
        return torch.cat([self.surfaces[i].s for i in self.setup_index[idx].tolist()])

    def batch(self, idx: torch.Tensor):
        """(x, s, y) of the samples idx. s is (1,3,H,W) where every pair is one setup's: the networks broadcast
        it, so the surface path runs once per batch instead of once per sample (the same gradient: the
        broadcast sums what the copies would each have received)."""
        idx = idx.to(self.x.device)  # sampled on the CPU (its generator), indexing where the pairs are
        s = self.surfaces[0].s if len(self.surfaces) == 1 else self.s_for(idx)
        return self.x[idx], s, self.y[idx]

    def to(self, device) -> "PairSet":
        """The pairs on `device` (a training's batches are then sampled there, with no copy per step)."""
        return PairSet(self.x.to(device), self.y.to(device), self.setup_index.to(device),
                       [surface.to(device) for surface in self.surfaces], self.role)

    def subset(self, count: int) -> "PairSet":
        """The first `count` pairs (the paper's 8 / 48 / 125 image budgets)."""
        return PairSet(self.x[:count], self.y[:count], self.setup_index[:count], self.surfaces, self.role)


def pairs_from_capture_sets(sets, role: str, split: str = "train", count: int | None = None) -> PairSet:
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}; use one of {ROLES}")
    xs, ys, idx, surfaces = [], [], [], []
    for k, cs in enumerate(sets):
        prj = cs.prj_train if split == "train" else cs.prj_test
        cam = cs.cam_train if split == "train" else cs.cam_test
        n = min(len(prj), len(cam))
        if count is not None:
            n = min(n, count)
        if n == 0:
            raise ValueError(f"setup '{cs.setup}' has no {split} pairs")
        prj_t, cam_t = to_tensor(prj[:n]), to_tensor(cam[:n])
        x, y = (cam_t, prj_t) if role == "compensation" else (prj_t, cam_t)
        xs.append(x)
        ys.append(y)
        idx.append(torch.full((n,), k, dtype=torch.long))
        surfaces.append(SurfaceTensors.from_capture_set(cs))
    return PairSet(torch.cat(xs), torch.cat(ys), torch.cat(idx), surfaces, role)
