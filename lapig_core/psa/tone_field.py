"""The fast path of PSA for large tonal moves: a smooth per-channel gain and offset field that every
backend's look passes through (issue 13).

    I' = clamp(I * exp(G) + O, 0, 1)
    G  = up(g) + beta_c * log(r / mean r)     r = I+ - I-, the surface's reachable range
    O  = up(o) + gamma_c * I-

g, o: (1,1,GRID,GRID) low-resolution fields (shared by the channels), upsampled bicubically (smooth: they move the tone of whole
regions, never the strokes). beta, gamma: one number per channel that let the look follow the
surface's own range at full resolution (a small bright feature on a black surface is where the look
may stay bright). Everything starts at the identity (zeros), so an un-adapted look passes through
unchanged, and is differentiable: PSA optimises it together with the backend's theta.

The backend's theta cannot make a large tonal move in PSA's budget (it moves the style network's
normalisation, a little per step); these 2 x GRID^2 + 6 numbers can, in a few steps.
"""
from __future__ import annotations

import torch
from torch.nn import functional as F

from ..lgst.base import LGSTBackend

GRID = 6  # low-res field side: regions of about a sixth of the frame
RANGE_FLOOR = 0.01  # below this the reachable range is treated as nothing (log stays finite)
# parameter scales: Adam moves every number by about lr per step, so these set the step of each kind
SCALE = {"gain": 1.0, "offset": 0.5, "beta": 2.0, "gamma": 1.0}


class ToneField(torch.nn.Module):
    """The field's parameters and the surface guide it was made for (I+ and I- at the working frame)."""

    def __init__(self, i_min: torch.Tensor, i_max: torch.Tensor, grid: int = GRID):
        super().__init__()
        self.grid = grid
        # one gain and one offset for all three channels: the field moves tone, not hue, so the
        # look's colour relations stay (a per-channel offset crushed whole channels on a dark
        # surface: a yellow look went green). Colour follows only the surface's own range (beta).
        device = i_min.device  # where the surface guide is, PSA runs
        self.gain = torch.nn.Parameter(torch.zeros(1, 1, grid, grid, device=device))
        self.offset = torch.nn.Parameter(torch.zeros(1, 1, grid, grid, device=device))
        self.beta = torch.nn.Parameter(torch.zeros(1, 3, 1, 1, device=device))
        self.gamma = torch.nn.Parameter(torch.zeros(1, 3, 1, 1, device=device))
        self.i_min, self.i_max = i_min.detach(), i_max.detach()
        # the range's mean over the frame fixes the guide's scale, so the same beta means the same
        # look at any resolution
        self.mean_range = float(self._range(self.i_min, self.i_max).mean())

    @staticmethod
    def _range(i_min, i_max):
        return (i_max - i_min).clamp_min(RANGE_FLOOR)

    def apply(self, look: torch.Tensor, i_min: torch.Tensor | None = None,
              i_max: torch.Tensor | None = None) -> torch.Tensor:
        """The adapted look (1,3,H,W); i_min / i_max: the surface at the look's size (default: the
        working frame's, resized when the look has another size)."""
        size = tuple(look.shape[-2:])
        i_min = self._at(self.i_min if i_min is None else i_min, size)
        i_max = self._at(self.i_max if i_max is None else i_max, size)
        log_range = torch.log(self._range(i_min, i_max) / self.mean_range)
        up = lambda f: F.interpolate(f, size=size, mode="bicubic", align_corners=False)  # noqa: E731
        gain = up(SCALE["gain"] * self.gain) + SCALE["beta"] * self.beta * log_range
        offset = up(SCALE["offset"] * self.offset) + SCALE["gamma"] * self.gamma * i_min
        return (look * torch.exp(gain) + offset).clamp(0, 1)

    @staticmethod
    def _at(t, size):
        t = t.to(torch.float32)
        return t if tuple(t.shape[-2:]) == size else F.interpolate(t, size=size, mode="bilinear",
                                                                   align_corners=False)

    def summary(self) -> dict:
        """What the field did, in words a person can read in result.json: the mean gain (x) and
        offset per channel, and how much the look follows the surface's range (beta)."""
        with torch.no_grad():
            gain = torch.exp(SCALE["gain"] * self.gain).mean(dim=(0, 2, 3)).expand(3)
            offset = (SCALE["offset"] * self.offset).mean(dim=(0, 2, 3)).expand(3)
            beta = (SCALE["beta"] * self.beta).flatten()
            gamma = (SCALE["gamma"] * self.gamma).flatten()
        r = lambda t: [round(float(v), 3) for v in t]  # noqa: E731
        return {"grid": self.grid, "mean_gain_rgb": r(gain), "mean_offset_rgb": r(offset),
                "follows_range_rgb": r(beta), "follows_black_level_rgb": r(gamma)}


class AdaptedLook(LGSTBackend):
    """A prepared backend with a ToneField after it: the look PSA optimises (theta and the field).

    It is an LGSTBackend itself, so the rest of the pipeline (native output, state, describe) takes it
    where it took the backend."""

    def __init__(self, backend: LGSTBackend, i_min: torch.Tensor, i_max: torch.Tensor, grid: int = GRID):
        self.backend = backend
        self.field = ToneField(i_min, i_max, grid)
        self.name = backend.name

    def backend_parameters(self) -> list[torch.Tensor]:
        return self.backend.parameters()

    def field_parameters(self) -> list[torch.Tensor]:
        return list(self.field.parameters())

    def parameters(self):
        return self.backend_parameters() + self.field_parameters()

    def forward(self):
        return self.field.apply(self.backend.forward())

    def render_at(self, surface):
        """The backend's look at the surface's size, through the field with the working frame's
        guide (I- and I+) resized: the log of a dim, noisy range would amplify another capture's
        noise, and the same guide keeps the native look the one PSA chose."""
        look = self.backend.render_at(surface)
        with torch.no_grad():
            return self.field.apply(look)

    def prepare(self, surface, prompt, seed=0, mix=None):
        """Prepare the backend again (a new sample); the field starts at the identity again."""
        self.backend.prepare(surface, prompt, seed=seed, mix=mix)
        with torch.no_grad():
            for p in self.field_parameters():
                p.zero_()

    def theta_distance(self):
        distance = getattr(self.backend, "theta_distance", None)
        return distance() if distance is not None else torch.zeros(())

    def describe(self):
        return self.backend.describe()

    def state(self):
        return {**self.backend.state(), "tone_field": [p.detach().clone() for p in self.field_parameters()]}

    def load_state(self, state):
        self.backend.load_state(state)
        with torch.no_grad():
            for p, v in zip(self.field_parameters(), state.get("tone_field") or []):
                p.copy_(v)
            if not state.get("tone_field"):  # a state of the bare backend: the identity field
                for p in self.field_parameters():
                    p.zero_()

    @property
    def surface(self):  # the resample baseline (tools/research/psa_resample) re-prepares on it
        return getattr(self.backend, "surface", None)
