# SPDX-License-Identifier: GPL-3.0-or-later
"""Where Add Projector puts a new projector: where the existing ones do not light the object.

The simplest honest rule: mirror the first projector's position across the plane through the object's
centre that holds the camera's view axis and the up axis. A bust lit from the front left is then lit
from the front right too, at the same distance and height. Where the mirror image lands on a projector
already there (the first stands on that plane, above or below the camera, or a second was mirrored
before), the first projector's position is swung around the object's vertical axis instead, to the side
farther from the others. The new projector looks at the object's centre.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..optics.placement import look_at

SWING_DEG = 60.0  # around the object, where mirroring lands on a projector already there
TOO_CLOSE = 0.25  # of the first projector's distance to the centre: two projectors that close share a view


@dataclass(frozen=True)
class AddedProjector:
    """position: (3,) world; rotation: (3,3) whose columns are the projector's local x, y, z axes (it shines
    along -z); side: 'left' or 'right' of the camera's view; how: 'mirrored' or 'swung'."""
    position: np.ndarray
    rotation: np.ndarray
    distance: float
    side: str
    how: str

    def sentence(self, name: str, target: str) -> str:
        way = "mirroring the first across the camera's view" if self.how == "mirrored" else \
            f"swinging the first {SWING_DEG:.0f} degrees around it"
        return (f"'{name}' placed {self.distance:.2f} m from '{target}', on its {self.side} as the camera sees it "
                f"({way})")


def _unit(v) -> np.ndarray:
    v = np.asarray(v, np.float64)
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else v


def _rotate_about(point, centre, axis, degrees) -> np.ndarray:
    """Rodrigues' rotation of `point` about the line through `centre` along `axis`."""
    k = _unit(axis)
    v = np.asarray(point, np.float64) - centre
    a = np.radians(degrees)
    return centre + v * np.cos(a) + np.cross(k, v) * np.sin(a) + k * (k @ v) * (1 - np.cos(a))


def added_projector(existing, centre, camera_position, up=(0.0, 0.0, 1.0)) -> AddedProjector:
    """The pose of the next projector. existing: (N,3) positions of the rig's projectors, the first first;
    centre: the object's centre; camera_position: the camera's."""
    existing = np.atleast_2d(np.asarray(existing, np.float64))
    centre = np.asarray(centre, np.float64)
    up = _unit(up)
    view = centre - np.asarray(camera_position, np.float64)
    right = np.cross(view, up)  # the camera's right, normal to the plane of its view axis and up
    if np.linalg.norm(right) < 1e-9:  # the camera looks straight down: the first projector's side instead
        right = np.cross(existing[0] - centre, up)
    right = _unit(right)
    first = existing[0]
    radius = float(np.linalg.norm(first - centre))
    mirrored = first - 2 * ((first - centre) @ right) * right

    def clearance(p) -> float:
        return float(np.min(np.linalg.norm(existing - p, axis=1)))

    position, how = mirrored, "mirrored"
    if clearance(mirrored) < TOO_CLOSE * radius:
        swings = [_rotate_about(first, centre, up, sign * SWING_DEG) for sign in (1, -1)]
        position, how = max(swings, key=clearance), "swung"
    side = "right" if (position - centre) @ right >= 0 else "left"
    distance = float(np.linalg.norm(position - centre))
    return AddedProjector(position, look_at(position, centre, up).rotation, distance, side, how)
