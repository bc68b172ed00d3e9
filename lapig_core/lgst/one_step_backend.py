# SPDX-License-Identifier: GPL-3.0-or-later
"""Optional LGST backend: the one-step image-to-image model (SD-Turbo class) as a look that PSA can adapt.

The look is the model card's image-to-image recipe written out so that it is differentiable in theta (the prompt's
embedding): the lit surface's latents noised to the timestep of `strength` (SD-Turbo: 2 steps x strength 0.5, t=499
of 1000, trailing spacing) with noise fixed by the seed, one UNet call without guidance, its clean-latent estimate
decoded. The preview as the prompt is typed (services/generate/prompt_preview) is this backend's stylize(): one UNet call;
Generate runs PSA on the same look. The pipeline is lapig_core/diffusion/one_step's (loaded once, memory checked).
"""
from __future__ import annotations

import os

import torch

from .base import LGSTUnavailable
from .ip2p_backend import PromptDiffusionBackend
from .styletransfer_backend import resize

NAME = "one-step"


def model_status(model: str | None) -> tuple[bool, str]:
    """(a pipeline folder is there, where / why not): file checks only."""
    if not model:
        return False, ("the one-step look needs the one-step model (SD-Turbo): download it in the add-on "
                       "preferences (Diffusion models), or use the default 'styletransfer' backend")
    folder = os.path.abspath(os.path.expanduser(model))
    if not os.path.isfile(os.path.join(folder, "model_index.json")):
        return False, f"no one-step model at {folder}: download it in the add-on preferences (Diffusion models)"
    return True, f"the one-step model from {folder}"


class OneStepBackend(PromptDiffusionBackend):
    """SD-Turbo's one step from the noised surface; theta = prompt embedding."""

    name = NAME
    takes_device = True

    def __init__(self, model: str | None = None, strength: float = 0.5, size: int = 512, device=None):
        """model: the one-step model's folder (the model manager's download). strength: how far the surface is
        noised before the step (0.5: SD-Turbo's image-to-image). size: the longer side the model works at."""
        if not 0.0 < float(strength) <= 1.0:
            raise ValueError(f"strength must be in (0, 1], got {strength}")
        if int(size) < 8:
            raise ValueError(f"size must be >= 8, got {size}")
        from ..common import compute_device

        self.model, self.strength, self.size = model or "", float(strength), int(size)
        self.device = compute_device.resolve(device or compute_device.AUTO)
        self._theta: list[torch.Tensor] = []
        self._info: dict = {}

    @classmethod
    def availability(cls, model: str | None = None, **options) -> tuple[bool, str]:
        return model_status(model)

    @property
    def pipe(self):
        from ..diffusion import one_step
        from ..diffusion.catalogue import ModelError

        ok, why = model_status(self.model)
        if not ok:
            raise LGSTUnavailable(why)
        try:
            return one_step.load(os.path.abspath(os.path.expanduser(self.model)), str(self.device))[0]
        except ModelError as exc:
            raise LGSTUnavailable(str(exc)) from None

    def prepare(self, surface, prompt, seed=0, mix=None):
        text, notes = self._take_surface(surface, prompt, mix, "the one-step model")
        pipe = self.pipe
        dtype = pipe.unet.dtype
        alphas = pipe.scheduler.alphas_cumprod
        self._t = max(0, min(len(alphas) - 1, int(round(len(alphas) * self.strength)) - 1))
        a_t = alphas[self._t].float().to(self.device)
        with torch.no_grad():
            image = resize(self.surface.to(self.device), self.work_size)
            latents = pipe.vae.encode((image * 2 - 1).to(dtype)).latent_dist.mode().float()
            latents = latents * pipe.vae.config.scaling_factor
            cond = self._encode_text(text).float()
        gen = torch.Generator().manual_seed(int(seed))  # CPU generator: the same noise on every device
        noise = torch.randn(latents.shape, generator=gen).to(self.device)
        self._noisy = a_t.sqrt() * latents + (1 - a_t).sqrt() * noise
        self._a_t = a_t
        self._theta = [cond.detach().clone().requires_grad_(True)]
        self._anchor = [cond.detach().clone()]
        self._info = {"backend": self.name, "model": self.model, "prompt": text, "seed": int(seed),
                      "strength": self.strength, "timestep": self._t, "size": list(self.work_size),
                      "device": str(self.device), "dtype": str(dtype).replace("torch.", ""), "styles": [],
                      "effects": [], "theta_numel": self._theta[0].numel(), "notes": notes}

    def forward(self):
        """One UNet call from the noised surface: its clean-latent estimate, decoded; differentiable in theta."""
        self._require_prepared()
        pipe = self.pipe
        dtype = pipe.unet.dtype
        out = pipe.unet(self._noisy.to(dtype), self._t, encoder_hidden_states=self._theta[0].to(dtype),
                        return_dict=False)[0].float()
        a_t = self._a_t
        if pipe.scheduler.config.get("prediction_type", "epsilon") == "v_prediction":
            x0 = a_t.sqrt() * self._noisy - (1 - a_t).sqrt() * out
        else:
            x0 = (self._noisy - (1 - a_t).sqrt() * out) / a_t.sqrt()
        image = pipe.vae.decode((x0 / pipe.vae.config.scaling_factor).to(pipe.vae.dtype), return_dict=False)[0]
        image = ((image.float() + 1) / 2).clamp(0, 1)
        return resize(image, self.out_size).to(self.surface.device)
