# SPDX-License-Identifier: GPL-3.0-or-later
"""A small fake surface (a classical model) and a cheap theta backend for the show's tests."""
import math

import numpy as np
import torch

from lapig.lapig_core.lgst.base import ThetaBackend
from lapig.lapig_core.photometric.classical import ClassicalModel
from lapig.lapig_core.photometric.classical_compensator import ClassicalCompensator, ClassicalSimulator
from lapig.lapig_core.photometric.surface_models import SurfaceModels
from lapig.lapig_core.psa.adaptation import PSASettings, warm_start_field
from lapig.lapig_core.psa.tone_field import AdaptedLook
from lapig.lapig_core.show.look_state import KeyedLook

H, W = 48, 64


def _t(a):
    return torch.from_numpy(np.ascontiguousarray(a, dtype=np.float32)).permute(2, 0, 1)[None]


def fake_models(h=H, w=W, seed=0) -> SurfaceModels:
    """A textured, tinted surface: albedo blotches, a little channel crosstalk and ambient light."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    albedo = 0.55 + 0.3 * np.sin(6 * x + 4 * y)[..., None] * np.array([1.0, 0.7, 0.4])
    albedo = np.clip(albedo + 0.02 * rng.standard_normal((h, w, 3)), 0.15, 1.0)
    m = albedo[..., None] * np.eye(3) * 0.9 + 0.03
    cm = ClassicalModel(2.2, 2.2, m.astype(np.float32), np.full((h, w, 3), 0.01, np.float32))
    refs = [cm.simulate(np.full((h, w, 3), v, np.float32)) for v in (0.0, 1.0, 0.5)]
    i_min, i_max, s = (_t(r) for r in refs)
    models = SurfaceModels(ClassicalCompensator(cm), ClassicalSimulator(cm), s, i_min, i_max)
    models.classical = cm
    return models


class StripesBackend(ThetaBackend):
    """Coloured stripes: theta = (colour, stripe frequency), both change the look."""

    name = "stripes-test"

    def prepare(self, surface, prompt, seed=0, mix=None):
        g = torch.Generator().manual_seed(seed)
        self.surface = surface
        colour = 0.3 + 0.6 * torch.rand(1, 3, 1, 1, generator=g)
        freq = torch.tensor([2.0 + 4.0 * float(torch.rand(1, generator=g))])
        self._theta = [colour.requires_grad_(True), freq.requires_grad_(True)]
        self._anchor = [colour.detach().clone(), freq.detach().clone()]
        self.prompt = prompt

    def forward(self):
        colour, freq = self._theta
        h, w = self.surface.shape[-2:]
        x = torch.linspace(0, 1, w)[None, None, None, :]
        y = torch.linspace(0, 1, h)[None, None, :, None]
        pattern = 0.5 + 0.5 * torch.sin(2 * math.pi * (freq * x + 0.5 * y))
        return (colour * (0.35 + 0.6 * pattern)).clamp(0, 1)

    def describe(self):
        return {"backend": self.name, "prompt": self.prompt, "styles": []}


def keyed_look(look, models) -> KeyedLook:
    """A keyed look as PSA's fast path leaves it: the backend prepared from the look's prompt and seed, its
    tone field moved by PSA's warm start (no network steps)."""
    backend = StripesBackend()
    backend.prepare(models.i_max, look.prompt, seed=look.seed)
    adapted = AdaptedLook(backend, models.i_min, models.i_max)
    with torch.no_grad():
        base = backend.forward().detach()
    warm_start_field(adapted, base, models, PSASettings(warm_start_steps=60))
    return KeyedLook(backend, adapted.state(), base, backend.name)


class CountingCompensator(torch.nn.Module):
    """Wraps a compensator, counting the frames it compensates."""

    def __init__(self, inner):
        super().__init__()
        self.inner, self.calls = inner, 0
        self.gamma_p = inner.gamma_p

    def cache_surface(self, s):
        pass

    def frame_inputs(self, height, width):
        return self.inner.frame_inputs(height, width)

    def forward(self, *args, **kwargs):
        self.calls += 1
        return self.inner(*args, **kwargs)
