# SPDX-License-Identifier: GPL-3.0-or-later
"""The one-step image-to-image model (SD-Turbo class) from a downloaded folder: loaded once on the planned device and
precision, then a preview of the lit surface as the prompt asks, at the size the model was trained for (512 px).

SD-Turbo takes no classifier-free guidance (guidance 0) and runs int(steps * strength) denoising steps: steps 2,
strength 0.5 is its single step, the model card's image-to-image recipe.
"""
from __future__ import annotations

import functools
import os

from . import device_fit
from .catalogue import ModelError
from .pipeline_folder import check_pipeline

PIPELINE_CLASS = "StableDiffusionImg2ImgPipeline"


@functools.lru_cache(maxsize=1)
def load(folder: str, choice: str = "auto"):
    """(pipeline, DevicePlan): the folder checked, its memory need checked, then loaded (seconds: kept)."""
    import torch
    from diffusers import StableDiffusionImg2ImgPipeline

    folder = os.path.abspath(os.path.expanduser(folder))
    index = check_pipeline(folder)
    if index.get("_class_name") not in (PIPELINE_CLASS, "StableDiffusionPipeline"):
        raise ModelError(f"{folder} holds a {index.get('_class_name')}: the one-step preview needs a Stable "
                         f"Diffusion text-to-image or image-to-image pipeline (SD-Turbo)")
    plan = device_fit.require_fit(folder, choice, "the one-step model")
    dtype = torch.float16 if plan.dtype == "float16" else torch.float32
    try:
        pipe = StableDiffusionImg2ImgPipeline.from_pretrained(folder, dtype=dtype, local_files_only=True,
                                                              safety_checker=None, requires_safety_checker=False)
    except (OSError, ValueError) as exc:
        raise ModelError(f"{folder} does not load as a pipeline ({type(exc).__name__}: {exc})") from None
    pipe = pipe.to(plan.device)
    pipe.set_progress_bar_config(disable=True)
    return pipe, plan


def preview(folder: str, image, prompt: str, size: int = 512, strength: float = 0.5, steps: int = 2, seed: int = 0,
            choice: str = "auto"):
    """image (1,3,H,W) in [0,1] -> the model's edit of it at size x size (1,3,size,size) in [0,1], on the CPU."""
    import torch
    import torch.nn.functional as F

    pipe, plan = load(os.path.abspath(os.path.expanduser(folder)), choice)
    if int(steps * strength) < 1:
        raise ValueError(f"steps x strength must be at least 1 (got {steps} x {strength})")
    work = F.interpolate(image.float().clamp(0, 1), size=(size, size), mode="bilinear", align_corners=False)
    gen = torch.Generator().manual_seed(int(seed))
    with torch.no_grad():
        out = pipe(prompt=prompt, image=work.to(plan.device, pipe.unet.dtype), strength=strength,
                   num_inference_steps=steps, guidance_scale=0.0, generator=gen, output_type="pt").images
    return out.float().clamp(0, 1).cpu()
