# SPDX-License-Identifier: GPL-3.0-or-later
"""Geometric blend weights of K projectors, in camera space and as each projector's alpha map.

Each projector's weight at a camera pixel is the product of
  - visibility: 0 where it does not reach (its CameraMap's valid mask);
  - quality: incidence (the cos of the angle its light meets the surface at: a grazing projector is dim
    and blurred) times pixel density (projector pixels per camera pixel, |det du/dx|: a finer image), each
    to a power, smoothed by a Gaussian within the reach so a crease or a noisy map makes no step;
  - an edge ramp: a smoothstep of the distance to where the others reach and this one does not, so a
    projector fades out towards its frame's edge or its shadow instead of stopping there. Edges no other
    projector reaches past (the object's outline) get no ramp.
The weights are normalised to sum 1 over the projectors that reach a pixel. The one place no blend can
be smooth is a point inside the object where two frames' hand-over edges cross (one side only this
projector, the other only that one); frames that overscan the object keep such crossings off it.
The weights are fractions of linear light; the alpha maps carry them into each projector's frame, and
`encode_alpha` puts them in the projector's signal (alpha ** (1 / gamma_p)), the factor a media server
multiplies the image by.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

from .camera_map import CameraMap
from .masked_filter import masked_gaussian


@dataclass(frozen=True)
class BlendSettings:
    """ramp, sigma: fractions of the camera image's larger side (the edge ramp's width, the Gaussian's
    sigma); the powers weigh incidence and pixel density against each other (0 ignores one)."""

    ramp: float = 0.15
    sigma: float = 0.02
    incidence_power: float = 1.0
    density_power: float = 0.5


def blend_weights(maps: Sequence[CameraMap], incidence: Sequence[np.ndarray | None] | None = None,
                  settings: BlendSettings = BlendSettings()) -> np.ndarray:
    """(K,H,W) float32 weights per camera pixel: summing to 1 where any projector reaches, 0 elsewhere.
    incidence: one (H,W) map per projector (or None for 1)."""
    maps = list(maps)
    side = max(maps[0].camera_shape)
    incidence = [None] * len(maps) if incidence is None else list(incidence)
    raw = np.stack([quality(m, inc, settings, side) * r
                    for m, inc, r in zip(maps, incidence, edge_ramps(maps, settings.ramp * side))])
    total = raw.sum(axis=0)
    reached = np.stack([m.valid for m in maps])
    even = reached / np.maximum(reached.sum(axis=0), 1)  # a reached pixel every weight missed: an even split
    return np.where(total > 1e-12, raw / np.maximum(total, 1e-30), even).astype(np.float32)


def quality(camera_map: CameraMap, incidence: np.ndarray | None, settings: BlendSettings, side: int) -> np.ndarray:
    """(H,W) incidence^a * density^b, smoothed within the projector's reach; 0 outside it."""
    q = np.power(camera_map.density(), settings.density_power)
    if incidence is not None:
        q = q * np.power(np.clip(np.asarray(incidence, np.float32), 0.0, 1.0), settings.incidence_power)
    q = masked_gaussian(q, camera_map.valid, settings.sigma * side)
    return np.maximum(q, 1e-6) * camera_map.valid  # reached: never exactly 0, so it can still be normalised


def edge_ramps(maps: Sequence[CameraMap], ramp_px: float) -> list[np.ndarray]:
    """Per projector (H,W) in [0,1]: 0 outside its reach, rising by a smoothstep over `ramp_px` camera pixels
    from the pixels others reach and it does not; 1 where no such pixel is near."""
    reached = np.stack([m.valid for m in maps])
    anyone = reached.any(axis=0)
    ramps = []
    for mine in reached:
        edge = anyone & ~mine  # where the light has to hand over to the others
        if not edge.any() or ramp_px <= 0:
            ramps.append(mine.astype(np.float32))
            continue
        dist = cv2.distanceTransform((~edge).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        t = np.clip(dist / ramp_px, 0.0, 1.0)
        ramps.append((t * t * (3 - 2 * t) * mine).astype(np.float32))
    return ramps


def alpha_maps(maps: Sequence[CameraMap], weights: np.ndarray) -> list[np.ndarray]:
    """(K,H,W) camera-space weights -> one (h_k,w_k) float32 linear alpha map per projector frame, in [0,1];
    beyond what the camera saw, the nearest alphas extend (no cut at the measured region's edge)."""
    return [np.clip(m.to_projector(w, outside=None), 0.0, 1.0) for m, w in zip(maps, weights)]


def encode_alpha(alpha: np.ndarray, gamma_p: float) -> np.ndarray:
    """A linear-light alpha map -> the factor on the projector's signal: (v * a^(1/g))^g = v^g * a."""
    return np.power(np.clip(alpha, 0.0, 1.0), np.float32(1.0 / gamma_p)).astype(np.float32)


# the Blend preview's colour per projector (1 red, 2 green, 3 blue, 4 yellow; more wrap around)
SHARE_COLOURS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0, 0.0))


def share_frames(maps: Sequence[CameraMap], weights: np.ndarray, gamma_p: Sequence[float]) -> list[np.ndarray]:
    """The Blend preview: one encoded (h_k,w_k,3) float32 frame per projector that lights its share of the
    object in its own colour (SHARE_COLOURS): in linear light colour_k * alpha_k, so where two projectors
    overlap their colours mix by the blend's weights and the light sums to one colour's worth."""
    out = []
    for k, (alpha, gp) in enumerate(zip(alpha_maps(maps, weights), gamma_p)):
        colour = np.asarray(SHARE_COLOURS[k % len(SHARE_COLOURS)], np.float32)
        linear = np.clip(alpha, 0.0, 1.0)[..., None] * colour
        out.append(np.power(linear, np.float32(1.0 / gp)).astype(np.float32))
    return out
