"""Reference-image styles: the look of a painting or a photo of a material, differentiable for PSA.

The style predictor turns each reference image into a 100-d style vector; several images mix by their
weights (Ghiasi et al.'s style interpolation is linear in that vector), and the prompt can add its own:
the catalogue look the offline backend picks for it, rendered on this surface and read by the same
predictor. The transformer renders the mixed vector on the surface.

theta = [style vector (100,), strength (1,)]. strength is Magenta's content blend: the vector used is
strength * style + (1 - strength) * the surface's own style vector, so 0 keeps the surface's look and
1 is the reference's. PSA moves both.
"""
from __future__ import annotations

import importlib.util

import numpy as np
import torch

from .base import LGSTUnavailable, ThetaBackend
from ..common.style_image import StyleImage, StyleImageError, load_style_image, parse_style_image_spec, prepare_array
from .styletransfer_backend import internal_shape, resize


def centre_square(img: torch.Tensor, side: int = 256) -> torch.Tensor:
    """(B,3,H,W) -> its centre square resized to side x side (what the predictor is fed, as in the package)."""
    h, w = img.shape[-2:]
    s = min(h, w)
    top, left = (h - s) // 2, (w - s) // 2
    return resize(img[..., top:top + s, left:left + s], (side, side))


def image_tensor(img: np.ndarray, device="cpu") -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(img)).permute(2, 0, 1)[None].float().to(device)


def normalised_weights(weights) -> list[float]:
    w = [float(x) for x in weights]
    if any(x < 0 for x in w) or sum(w) <= 0:
        raise ValueError(f"style weights must be non-negative and not all zero, got {w}")
    return [x / sum(w) for x in w]


def mix_vectors(vectors: list[torch.Tensor], weights) -> torch.Tensor:
    """The weighted mean of style vectors (weights normalised to sum 1): differentiable in each."""
    if len(vectors) != len(weights) or not vectors:
        raise ValueError(f"{len(vectors)} style vectors and {len(weights)} weights")
    return sum(w * v for w, v in zip(normalised_weights(weights), vectors))


class ArbitraryStyleBackend(ThetaBackend):
    """Reference images (and optionally the prompt's catalogue look) -> a style vector -> the look."""

    name = "arbitrary"

    def __init__(self, style_images=(), strength: float = 1.0, prompt_weight: float | None = None,
                 internal_size: int = 256, blend: float = 0.0, jitter: float = 0.0):
        """style_images: paths, 'path:weight' strings, (path or RGB array, weight) pairs, or StyleImages.
        strength: the content blend in [0, 1] (1: the reference's style vector as it is).
        prompt_weight: share of the prompt's catalogue look in the mix; default 0 with images, 1 without.
        internal_size: the transformer's working long side (256: the working frame's, fast enough for PSA on a
        CPU; the package uses 384, whose strokes are finer).
        blend: share of the surface mixed back in pixel space after the transformer.
        """
        if not 0.0 <= strength <= 1.0:
            raise ValueError(f"strength must be in [0, 1], got {strength}")
        if prompt_weight is not None and not 0.0 <= prompt_weight <= 1.0:
            raise ValueError(f"prompt_weight must be in [0, 1], got {prompt_weight}")
        if not 0.0 <= blend <= 1.0:
            raise ValueError(f"blend must be in [0, 1], got {blend}")
        if isinstance(style_images, (str, StyleImage)) or (isinstance(style_images, tuple) and len(style_images) == 2
                                                           and isinstance(style_images[1], (int, float))):
            style_images = [style_images]
        self.style_specs = list(style_images)
        self.strength, self.prompt_weight = float(strength), prompt_weight
        self.internal_size, self.blend, self.jitter = int(internal_size), float(blend), float(jitter)
        self._theta: list[torch.Tensor] = []
        self._info: dict = {}

    @classmethod
    def availability(cls, **options) -> tuple[bool, str]:
        from .arbitrary_net import PREDICT_FILE, TRANSFORM_FILE, model_file

        try:
            paths = [model_file(PREDICT_FILE), model_file(TRANSFORM_FILE)]
        except LGSTUnavailable as exc:
            return False, str(exc)
        if importlib.util.find_spec("onnx") is None:
            return False, "needs the 'onnx' package to read the style networks (pip install onnx)"
        return True, f"offline: any reference image, networks from {paths[0].parent}"

    # -- inputs ----------------------------------------------------------------------------------
    def style_images(self) -> list[tuple[StyleImage, float]]:
        """The reference images, read and checked (StyleImageError names a bad one)."""
        out = []
        for spec in self.style_specs:
            weight = 1.0
            if isinstance(spec, tuple):
                spec, weight = spec
            if isinstance(spec, str):
                path, w = parse_style_image_spec(spec)
                out.append((load_style_image(path), float(weight) * w))
            elif isinstance(spec, StyleImage):
                out.append((spec, float(weight)))
            else:  # an array from code: RGB
                out.append((prepare_array(spec, name=f"style image {len(out) + 1}"), float(weight)))
        if out:
            normalised_weights([w for _, w in out])  # refuse all-zero weights before any network runs
        return out

    def style_vector_of(self, image: torch.Tensor) -> torch.Tensor:
        """(1,3,H,W) in [0,1] -> its style vector (100,), differentiable in the image."""
        from .arbitrary_net import STYLE_SIZE, load_predictor

        return load_predictor(image.device)(centre_square(image, STYLE_SIZE))[0]

    def _prompt_vector(self, surface, prompt, seed, mix, notes) -> tuple[torch.Tensor | None, list]:
        """The style vector of the catalogue look the offline backend picks for the prompt (or the
        explicit mix), rendered on this surface; None with a note when that cannot be made here."""
        from .base import get_backend

        try:
            look_backend = get_backend("styletransfer", internal_size=256, blend=0.0)
            small = resize(surface, internal_shape(*surface.shape[-2:], 256))
            look = look_backend.stylize(small, prompt, seed=seed, mix=mix)
        except (LGSTUnavailable, ValueError, RuntimeError) as exc:
            notes.append(f"the prompt's look could not be made ({exc}); used the reference images only")
            return None, []
        with torch.no_grad():
            vector = self.style_vector_of(look)
        info = look_backend.describe()
        notes.extend(f"prompt: {n}" for n in info.get("notes", []))
        return vector, info.get("styles", [])

    # -- setup -----------------------------------------------------------------------------------
    def prepare(self, surface, prompt, seed=0, mix=None):
        from .arbitrary_net import load_transformer

        if surface.ndim != 4 or surface.shape[:2] != (1, 3):
            raise ValueError(f"surface must be (1,3,H,W), got {tuple(surface.shape)}")
        images = self.style_images()
        text = (prompt or "").strip()
        prompt_weight = self.prompt_weight if self.prompt_weight is not None else (0.0 if images else 1.0)
        if not images and prompt_weight == 0:
            raise StyleImageError("choose a style image (or give the prompt a share of the mix)")
        self.surface = surface.detach().float().clamp(0, 1)
        device = self.surface.device
        notes, styles = [], []
        with torch.no_grad():
            vectors = [self.style_vector_of(image_tensor(img.image, device)) for img, _ in images]
            image_weights = normalised_weights([w for _, w in images]) if images else []
            for img, _ in images:
                notes.extend(f"{img.path}: {n}" for n in img.notes)
            prompt_vector = None
            if prompt_weight > 0 and (text or mix is not None):
                prompt_vector, styles = self._prompt_vector(self.surface, text, seed, mix, notes)
                if prompt_vector is None and not images:
                    raise LGSTUnavailable(notes[-1])
            elif prompt_weight > 0:
                notes.append("no prompt: the mix is the reference images only")
            elif text or mix is not None:  # said, so an artist does not wonder why the prompt did nothing
                notes.append("the prompt and style mix are not used: the look is the style images' "
                             "(give the prompt a share to mix its look in)")
            if prompt_vector is None:
                prompt_weight = 0.0
            else:
                prompt_weight = prompt_weight if images else 1.0
                vectors.append(prompt_vector)
            weights = [w * (1 - prompt_weight) for w in image_weights]
            style = mix_vectors(vectors, weights + ([prompt_weight] if prompt_vector is not None else []))
            own = self.style_vector_of(self.surface)  # the content's own style, for the content blend
        self.net = load_transformer(device)
        self.size = tuple(self.surface.shape[-2:])
        with torch.no_grad():  # the contract convs do not depend on the style: run them once
            self._contract = self.net.contract(resize(self.surface, internal_shape(*self.size, self.internal_size)))
        self._own = own.detach()
        style = style.detach().clone()
        strength = torch.tensor([self.strength], device=device)
        self._anchor = [style.clone(), strength.clone()]
        if self.jitter > 0:
            gen = torch.Generator().manual_seed(int(seed))
            style = style + self.jitter * style.abs().mean() * torch.randn(style.shape, generator=gen).to(device)
        self._theta = [style.requires_grad_(True), strength.requires_grad_(True)]
        self._info = {"backend": self.name, "prompt": text, "seed": int(seed),
                      "style_images": [dict(img.summary(), weight=round(w * (1 - prompt_weight), 4))
                                       for (img, _), w in zip(images, image_weights)],
                      "prompt_weight": round(float(prompt_weight), 4),
                      "styles": styles, "strength": self.strength, "internal_size": self.internal_size,
                      "blend": self.blend, "theta_numel": sum(t.numel() for t in self._theta), "notes": notes}

    # -- rendering -------------------------------------------------------------------------------
    def mixed_vector(self) -> torch.Tensor:
        """strength * style + (1 - strength) * the surface's own vector (strength kept in [0, 1])."""
        style, strength = self._theta
        s = strength.clamp(0.0, 1.0)
        return s * style + (1 - s) * self._own

    def forward(self):
        self._require_prepared()
        return self._look(self._contract, self.surface)

    def _look(self, contract, surface):
        styled = self.net.forward_from_contract(contract, self.net.style_params(self.mixed_vector()))
        styled = resize(styled, tuple(surface.shape[-2:]))
        return (1.0 - self.blend) * styled + self.blend * surface

    def render_at(self, surface):
        """The same style at the transformer's internal size, blended with the finer surface."""
        self._require_prepared()
        surface = surface.detach().float().clamp(0, 1).to(self.surface.device)
        with torch.no_grad():
            contract = self.net.contract(resize(surface, internal_shape(*surface.shape[-2:], self.internal_size)))
            return self._look(contract, surface).clamp(0, 1)

    def describe(self):
        self._require_prepared()
        info = dict(self._info)
        info["strength_now"] = round(float(self._theta[1].detach().clamp(0, 1)), 4)
        return info
