"""The default, offline LGST backend: prompt -> mix of the 26 Dumoulin styles -> differentiable look.

theta is the mixed conditional-instance-norm scale/shift of every layer (990 numbers), initialised from
the prompt's style mix. Those few numbers steer colour, texture and stroke of the whole image, so
gradient descent on them (PSA) changes the look smoothly while the conv weights stay fixed.
"""
from __future__ import annotations

import importlib.util

import torch
import torch.nn.functional as F

from .base import LGSTUnavailable, ThetaBackend
from .effects import effects_for_prompt


def internal_shape(h: int, w: int, internal_size: int) -> tuple[int, int]:
    """(h, w) scaled so the longer side is about internal_size, each a multiple of 4 (the net needs it)."""
    scale = internal_size / max(h, w)
    return max(4, int(round(h * scale / 4)) * 4), max(4, int(round(w * scale / 4)) * 4)


def resize(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """Bilinear when enlarging, area average when shrinking (no aliasing); both differentiable."""
    if tuple(x.shape[-2:]) == tuple(size):
        return x
    if size[0] >= x.shape[-2] and size[1] >= x.shape[-1]:
        return F.interpolate(x, size=size, mode="bilinear", align_corners=False)
    return F.interpolate(x, size=size, mode="area")


def stylize_mix(surface: torch.Tensor, mix, internal_size: int = 512, blend: float = 0.15,
                params: dict | None = None) -> torch.Tensor:
    """One pass of the pipeline for a given mix (or explicit CIN params); used by previews and tests."""
    from .style_net import load_style_net

    net = load_style_net(surface.device)
    params = params if params is not None else net.style_params(mix)
    big = resize(surface, internal_shape(*surface.shape[-2:], internal_size))
    styled = resize(net.forward_with_params(big, params), tuple(surface.shape[-2:]))
    return (1.0 - blend) * styled + blend * surface


class StyleTransferBackend(ThetaBackend):
    """Offline backend: MiniLM picks a style mix for the prompt, the torch style net renders it."""

    name = "styletransfer"

    def __init__(self, internal_size: int = 512, blend: float = 0.15, top_k: int = 3,
                 temperature: float | None = None, jitter: float = 0.0, effects: str | list = "auto"):
        """internal_size: the style net's working resolution (its styles were trained near 512 px).
        blend: share of the input surface mixed back in, so the content stays recognisable.
        jitter: std of seeded noise added to theta at prepare (0 = the mix exactly; >0 for PSA restarts).
        effects: 'auto' (from the prompt's words), a list of effect objects, or None.
        """
        if not 0.0 <= blend <= 1.0:
            raise ValueError(f"blend must be in [0, 1], got {blend}")
        self.internal_size, self.blend, self.top_k = int(internal_size), float(blend), int(top_k)
        self.temperature, self.jitter, self.effects_spec = temperature, float(jitter), effects
        self._theta: list[torch.Tensor] = []
        self._info: dict = {}

    @classmethod
    def availability(cls, **options) -> tuple[bool, str]:
        from .style_net import model_path

        try:
            path = model_path()
        except LGSTUnavailable as exc:
            return False, str(exc)
        if importlib.util.find_spec("onnx") is None:
            return False, "needs the 'onnx' package to read the style network (pip install onnx)"
        from .prompt_mapping import prompt_model_status

        ok, why = prompt_model_status()
        if not ok:
            return True, f"style net found at {path}; prompts need the text model ({why}); explicit mixes work"
        return True, f"offline: 26 styles from {path.name}, prompts mapped with all-MiniLM-L6-v2"

    # -- setup -----------------------------------------------------------------------------------
    def prepare(self, surface, prompt, seed=0, mix=None):
        from . import prompt_mapping as pm
        from .style_net import load_style_net

        if surface.ndim != 4 or surface.shape[:2] != (1, 3):
            raise ValueError(f"surface must be (1,3,H,W), got {tuple(surface.shape)}")
        text, notes = pm.validate_prompt(prompt) if (mix is None or prompt) else ("", [])
        if self.effects_spec == "auto":
            self._effects = effects_for_prompt(text)
        else:
            self._effects = list(self.effects_spec or [])
        if mix is not None:
            chosen = pm.resolve_mix(mix)
            notes.append("style mix given explicitly")
        else:
            hints = [e.style_hint for e in self._effects if getattr(e, "style_hint", "")]
            query = ", ".join([text] + hints)
            if hints:
                notes.append(f"style chosen for the effects' look too: '{', '.join(hints)}'")
            info = pm.explain_prompt(query, k=self.top_k, temperature=self.temperature)
            chosen, notes = info["mix"], notes + info["notes"]
        self.net = load_style_net(surface.device)
        self.surface = surface.detach().float().clamp(0, 1)
        self.size = tuple(self.surface.shape[-2:])
        # the content input of the net is fixed during PSA: resize it and run its first conv once
        with torch.no_grad():
            self._stem = self.net.stem(resize(self.surface, internal_shape(*self.size, self.internal_size)))
        mix_vec = pm.mix_vector(chosen)
        params = self.net.style_params(mix_vec)
        gen = torch.Generator().manual_seed(int(seed))
        self._layers = list(params)
        self._theta, self._anchor = [], []
        for name in self._layers:
            for t in params[name]:
                t = t.detach().clone()
                self._anchor.append(t.clone())  # the prompt's choice, before any jitter
                if self.jitter > 0:
                    noise = torch.randn(t.shape, generator=gen).to(t.device)
                    t = t + self.jitter * t.abs().mean() * noise
                self._theta.append(t.requires_grad_(True))
        self._info = {"backend": self.name, "prompt": text, "seed": int(seed),
                      "styles": [(n, round(float(w), 4)) for n, w in chosen],
                      "effects": [e.label() for e in self._effects],
                      "internal_size": self.internal_size, "blend": self.blend,
                      "theta_numel": sum(t.numel() for t in self._theta), "notes": notes}

    def _params(self) -> dict:
        it = iter(self._theta)
        return {name: (next(it), next(it)) for name in self._layers}

    # -- rendering -------------------------------------------------------------------------------
    def forward(self):
        self._require_prepared()
        return self._look(self._stem, self.surface)

    def _look(self, stem, surface):
        """The styled content at the net's internal size, resized to the surface and blended with it."""
        styled = resize(self.net.forward_from_stem(stem, self._params()), tuple(surface.shape[-2:]))
        out = (1.0 - self.blend) * styled + self.blend * surface
        for effect in self._effects:
            out = effect(out)
        return out

    def render_at(self, surface):
        """The same style strokes (the net runs at its internal size, as in PSA), blended with the
        finer surface, so the look keeps the surface's own detail at any output size."""
        self._require_prepared()
        surface = surface.detach().float().clamp(0, 1).to(self.surface.device)
        with torch.no_grad():
            stem = self.net.stem(resize(surface, internal_shape(*surface.shape[-2:], self.internal_size)))
            return self._look(stem, surface).clamp(0, 1)

    def describe(self):
        self._require_prepared()
        return dict(self._info)

    def state(self):
        return {"theta": [p.detach().clone() for p in self.parameters()], "describe": self.describe()}
