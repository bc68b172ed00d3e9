# SPDX-License-Identifier: GPL-3.0-or-later
"""The rig's calibration as an MPCDI 2.0 package: '2d', each projector's warp and blend from its capture
(below); 'sl' (shader lamp), each projector's pose, frustum and 3D surface points (write_rig_mpcdi_sl).

The content space is the camera's image (the view the look was made in): a media server that plays
camera-space content through this package shows it as the camera saw the looks. Per projector, one buffer
with one region filling it:
  - warp: each projector pixel's normalised camera coordinates (x / W, y / H), the inverse of its CameraMap
    (CameraMap.to_projector of the camera's pixel grid); NaN off the footprint, where the camera saw none of
    its light (the spec's "unknown");
  - alpha: blend.alpha_maps of blend.blend_weights, linear, written with the blend probe's gamma embedded
    (JointModel.alpha_gammas; the decode and encode gamma the same);
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
                             gamma=model.alpha_gammas[k], signal_gamma=model.alpha_gammas[k])
        buffers.append(MpcdiBuffer(id=ident, resolution=size, regions=(region,)))
    return buffers


def write_rig_mpcdi(path, model: JointModel, names: Sequence[str], weights: np.ndarray | None = None,
                    version: str = "2.0"):
    """Write the '2d' package of the rig to `path` (.mpcdi), whole or not at all; returns its path. ValueError
    or OSError (one line) when it cannot, the previous file at `path` kept."""
    return write_mpcdi(path, "2d", mpcdi_buffers(model, names, weights), version=version)


# ---- the 'sl' (shader lamp) profile: nDisplay, TouchDesigner ----
# Axis convention written: Blender world coordinates, Z up, right-handed, metres (geometricUnit 'm').
# A projector's coordinate frame: position = its object's world location; yaw axis = its local +Y (image
# up), pitch axis = its local +X (image right), roll axis = its local -Z (the throw direction); the
# frustum's yaw, pitch and roll are 0 (the frame carries the orientation), its edge angles come from the
# lens (throw ratio and shift, lapig_core/optics/projector_model).

SL_AXES = ("LAPIG shader-lamp package. 3D data: Blender world coordinates, Z up, right-handed, metres. "
           "Coordinate frame: position = the projector object's world location; yawAxis = its local +Y (image "
           "up), pitchAxis = its local +X (image right), rollAxis = its local -Z (throw direction). Frustum "
           "yaw = pitch = roll = 0; edge angles from the lens (throw ratio, shift). Warp: the surface point each "
           "texel's projector pixel ray hits (NaN: misses).")
SL_TEXEL_STEP = 8  # a texel every 8th projector pixel (3.6: the warp grid may be coarser than the region)


def sl_frustum(model) -> "MpcdiFrustum":
    """The frustum of a ProjectorModel: a pinhole with fx = fy = throw * width, the principal point moved
    by the lens shift (pixel edges at 0 and width; image y down)."""
    from ..export.mpcdi_model import MpcdiFrustum

    f = model.throw_ratio * model.width
    cx = (0.5 + model.shift_x) * model.width
    cy = (0.5 - model.shift_y) * model.height
    return MpcdiFrustum.from_pinhole(f, f, cx, cy, (model.width, model.height))


def sl_coordinate_frame(matrix_world) -> "MpcdiCoordinateFrame":
    """A projector's pose from its object's 4x4 world matrix (scale ignored): see the convention above."""
    from ..export.mpcdi_model import MpcdiCoordinateFrame

    m = np.asarray(matrix_world, dtype=np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    vec = lambda v: tuple(float(c) for c in v)  # noqa: E731
    return MpcdiCoordinateFrame(position=vec(m[:3, 3]), yaw_axis=vec(rot[:, 1]), pitch_axis=vec(rot[:, 0]),
                                roll_axis=vec(-rot[:, 2]))


def sl_texel_pixels(model, step: int = SL_TEXEL_STEP) -> np.ndarray:
    """(h', w', 2) the projector pixels (x, y) the 'sl' warp's texels sample: a uniform grid from the first
    pixel to the last (both ends included, 3.6), about every `step` pixels, at least 2 per side."""
    nx = max(2, -(-(model.width - 1) // step) + 1)
    ny = max(2, -(-(model.height - 1) // step) + 1)
    xs = np.linspace(0.0, model.width - 1, nx)
    ys = np.linspace(0.0, model.height - 1, ny)
    xx, yy = np.meshgrid(xs, ys)
    return np.stack([xx, yy], axis=-1)


def sl_buffers(names: Sequence[str], models, matrices, points, alphas, gammas=None) -> list[MpcdiBuffer]:
    """One 'sl' MpcdiBuffer per projector: models (ProjectorModel), matrices (4x4 world), points ((h', w', 3)
    world surface points of sl_texel_pixels, NaN where the ray misses), alphas ((height, width) linear blend
    weights)."""
    buffers = []
    for k, ident in enumerate(_ids(names)):
        model = models[k]
        gamma = float(gammas[k]) if gammas is not None else float(model.gamma)
        size = (int(model.width), int(model.height))
        region = MpcdiRegion(id=f"{ident} region", resolution=size, x=0.0, y=0.0, xsize=1.0, ysize=1.0,
                             warp=np.asarray(points[k], dtype=np.float32),
                             alpha=np.asarray(alphas[k], dtype=np.float64), gamma=gamma, signal_gamma=gamma,
                             frustum=sl_frustum(model), coordinate_frame=sl_coordinate_frame(matrices[k]))
        buffers.append(MpcdiBuffer(id=ident, resolution=size, regions=(region,)))
    return buffers


def write_rig_mpcdi_sl(path, names, models, matrices, points, alphas, gammas=None, version: str = "2.0"):
    """Write the 'sl' package (3D points in metres, Blender world: Z up, right-handed) whole or not at all;
    returns its path. ValueError or OSError (one line) when it cannot, the previous file at `path` kept."""
    return write_mpcdi(path, "sl", sl_buffers(names, models, matrices, points, alphas, gammas),
                       geometric_unit="m", comment=SL_AXES, version=version)
