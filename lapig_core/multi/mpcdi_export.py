# SPDX-License-Identifier: GPL-3.0-or-later
"""The rig's calibration as an MPCDI 2.0 '2d' package: each projector's warp and blend from its capture.

The content space is the camera's image (the view the look was made in): a media server that plays
camera-space content through this package shows it as the camera saw the looks. Per projector, one buffer
with one region filling it:
  - warp: each projector pixel's normalised camera coordinates (x / W, y / H), the inverse of its CameraMap
    (CameraMap.to_projector of the camera's pixel grid); NaN off the footprint, where the camera saw none of
    its light (the spec's "unknown");
  - alpha: blend.alpha_maps of blend.blend_weights, linear, written with the projector's gamma embedded;
    in camera space the alphas of overlapping projectors sum to 1.
The projector images LAPIG exports already carry their blend and compensation; the package is for other
content the server plays across the same projectors.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..export.mpcdi import MpcdiBuffer, MpcdiRegion, write_mpcdi
from .blend import alpha_maps, blend_weights
from .joint_model import JointModel


def _ids(names: Sequence[str]) -> list[str]:
    """Buffer ids from projector names: unique, without blanks at the ends."""
    out = []
    for k, name in enumerate(names):
        base = (str(name).strip() or f"projector_{k + 1}")
        ident = base if base not in out else f"{base}_{k + 1}"
        out.append(ident)
    return out


def projector_warp(model: JointModel, k: int) -> np.ndarray:
    """(h_k, w_k, 2) float32: projector k's pixels' normalised camera coordinates; NaN off its footprint."""
    m = model.maps[k]
    h, w = m.camera_shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    uv = np.stack([(xx + 0.5) / w, (yy + 0.5) / h], axis=-1)  # pixel centres, normalised to (0, 1)
    warp = np.clip(m.to_projector(uv, outside=None), 0.0, 1.0)
    warp[~m.footprint()] = np.nan
    return warp.astype(np.float32)


def mpcdi_buffers(model: JointModel, names: Sequence[str], weights: np.ndarray | None = None) -> list[MpcdiBuffer]:
    """One MpcdiBuffer per projector of the joint model (weights: (K,H,W) blend weights; None: blend_weights)."""
    weights = blend_weights(model.maps) if weights is None else weights
    alphas = alpha_maps(model.maps, weights)
    buffers = []
    for k, (ident, camera_map, alpha) in enumerate(zip(_ids(names), model.maps, alphas)):
        size = camera_map.projector_size
        region = MpcdiRegion(id=f"{ident} region", resolution=size, x=0.0, y=0.0, xsize=1.0, ysize=1.0,
                             warp=projector_warp(model, k), alpha=alpha.astype(np.float64),
                             gamma=model.gamma_p[k], signal_gamma=model.gamma_p[k])
        buffers.append(MpcdiBuffer(id=ident, resolution=size, regions=(region,)))
    return buffers


def write_rig_mpcdi(path, model: JointModel, names: Sequence[str], weights: np.ndarray | None = None):
    """Write the '2d' package of the rig to `path` (.mpcdi), whole or not at all; returns its path. ValueError
    or OSError (one line) when it cannot, the previous file at `path` kept."""
    return write_mpcdi(path, "2d", mpcdi_buffers(model, names, weights))
