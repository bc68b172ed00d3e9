# SPDX-License-Identifier: GPL-3.0-or-later
"""The spot cone a projector light needs: just wide enough for the projector's frame, as long as the object.

The light's image texture, not the cone, bounds the frame (blender/projector_nodes), so the cone only has to
contain every ray through the frame: its half-angle is the frame corner's angle off the axis (lens shift
included) plus a margin. A cone that is wider gains nothing and draws across the whole viewport (a spot of
nearly 180 degrees draws its end circle almost in the light's plane, as two long arcs).
"""
from __future__ import annotations

import math

import numpy as np

from .projector_model import ProjectorModel

CONE_MARGIN = math.radians(2.0)  # beyond the frame's corner: a corner pixel's rays stay inside the cone
LARGEST_SPOT = math.pi * 0.999  # Blender's spot_size is at most pi
REACH_MARGIN = 1.1  # the drawn cone ends past the object's farthest corner


def corner_half_angle(model: ProjectorModel) -> float:
    """The largest angle off the projector's axis of a ray through the frame's edge (radians)."""
    sx, sy = model.uv_scale()
    # u = 0.5 + shift_x + sx * x / d: the frame's edges u = 0 and u = 1 at d = 1
    xs = [(u - 0.5 - model.shift_x) / sx for u in (0.0, 1.0)]
    ys = [(v - 0.5 - model.shift_y) / sy for v in (0.0, 1.0)]
    return max(math.atan(math.hypot(x, y)) for x in xs for y in ys)


def spot_size(model: ProjectorModel) -> float:
    """The full cone angle (Blender's spot_size) that covers the frame with CONE_MARGIN to spare."""
    return min(2.0 * (corner_half_angle(model) + CONE_MARGIN), LARGEST_SPOT)


def reach(origin, points) -> float:
    """How far the cone is drawn: past the farthest of `points` (an object's bounding box corners) from the
    projector at `origin`, by REACH_MARGIN."""
    offsets = np.asarray(points, np.float64).reshape(-1, 3) - np.asarray(origin, np.float64)
    return float(np.linalg.norm(offsets, axis=1).max()) * REACH_MARGIN
