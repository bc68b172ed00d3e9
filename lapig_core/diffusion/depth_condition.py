# SPDX-License-Identifier: GPL-3.0-or-later
"""The object's depth as the projector sees it, as the depth adapter's conditioning (issue 53, item 3).

    image = depth_image(geometry, h, w)          # (1,3,h,w) in [0,1], or None where the geometry has no depth
    adapter = load_adapter(folder, device, dtype) # a T2I-Adapter (TencentARC/t2iadapter_depth_sd15v2 or a tiny one)
    features = adapter_features(adapter, image, unet, scale)  # once per look: the UNet adds them at every step

The adapter was trained on MiDaS depth maps: relative inverse depth, near bright and far dark, the background black.
The projector's depth (lgst/world/geometry.LookGeometry: metres along its axis, from Blender's ray casts) is turned
into that: inverse depth spread over [NEAR_FLOOR, 1] on the object (so a flat wall still stands out from the black
around it), 0 off it. The captured surface of a real rig without a 3D model has no depth (geometry source
'capture'): nothing to condition on, and the look says so. The adapter takes no normals.
"""
from __future__ import annotations

import functools
import os

import numpy as np

from .catalogue import ModelError
from .pipeline_folder import check_model

ADAPTER_CLASS = "T2IAdapter"
NEAR_FLOOR = 0.25  # the farthest point of the object: above the black of the background
NO_DEPTH = ("the object's depth as the projector sees it is not known here (no 3D model of it, or the joint path of "
            "several projectors): the drawing is not conditioned on its depth")


def depth_image(geometry, h: int, w: int):
    """(1,3,h,w) float32 torch image of the object's relative inverse depth at h x w, or None where the geometry
    has none (None, the captured surface, nothing on the object)."""
    import torch

    from ..lgst.world.geometry import resized

    if geometry is None or isinstance(geometry, str) or getattr(geometry, "source", "") != "scene":
        return None
    g = resized(geometry, h, w)
    valid = g.valid & np.isfinite(g.depth) & (np.nan_to_num(g.depth) > 0)
    if not valid.any():
        return None
    q = np.where(valid, 1.0 / np.where(valid, g.depth, 1.0), 0.0)
    near, far = float(q[valid].max()), float(q[valid].min())
    span = near - far
    rel = (q - far) / span if span > 1e-9 else np.ones_like(q)
    out = np.where(valid, NEAR_FLOOR + (1.0 - NEAR_FLOOR) * rel, 0.0).astype(np.float32)
    return torch.from_numpy(out)[None, None].repeat(1, 3, 1, 1)


@functools.lru_cache(maxsize=2)
def load_adapter(folder: str, device: str, dtype: str):
    """The adapter from its folder (checked first: one clear line for a folder that is not one), frozen, on
    device in dtype ('float16' / 'float32')."""
    import torch
    from diffusers import T2IAdapter

    folder = os.path.abspath(os.path.expanduser(folder))
    check_model(folder, ADAPTER_CLASS)
    # TencentARC's depth adapter has a .bin only: diffusers reads it with torch.load(weights_only=True), tensors
    # and no code
    safetensors = any(name.endswith(".safetensors") for name in os.listdir(folder))
    try:
        adapter = T2IAdapter.from_pretrained(folder, local_files_only=True, torch_dtype=getattr(torch, dtype),
                                             use_safetensors=safetensors)
    except (OSError, ValueError, RuntimeError) as exc:
        raise ModelError(f"{folder} does not load as a T2I-Adapter ({type(exc).__name__}: {exc})") from None
    return adapter.to(torch.device(device)).eval().requires_grad_(False)


def check_fits(adapter, unet) -> None:
    """The adapter's features must have the UNet's block widths (an SD 1.5 adapter on an SD 1.5 UNet)."""
    want = list(unet.config.block_out_channels)
    have = list(adapter.config.channels)
    if have != want[:len(have)] or len(have) != len(want):
        raise ModelError(f"the depth adapter is for a UNet with blocks {have}, the InstructPix2Pix model has {want}: "
                         f"choose the Stable Diffusion 1.5 depth adapter (TencentARC/t2iadapter_depth_sd15v2)")


def adapter_features(adapter, image, unet, scale: float = 1.0) -> list:
    """The adapter's features of the depth image (1,3,H,W) at the UNet's dtype and device, each times scale:
    computed once, added by the UNet at each step (down_intrablock_additional_residuals)."""
    import torch

    check_fits(adapter, unet)
    channels = adapter.config.in_channels
    image = image[:, :1].repeat(1, channels, 1, 1) if channels != image.shape[1] else image
    with torch.no_grad():
        features = adapter(image.to(unet.device, adapter.dtype))
    return [(f * scale).to(unet.dtype) for f in features]


def residuals(features: list, batch: int) -> list:
    """A fresh list for one UNet call (the UNet pops from it), each feature repeated to the call's batch."""
    return [f.expand(batch, *f.shape[1:]) if f.shape[0] != batch else f for f in features]
