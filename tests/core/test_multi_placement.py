# SPDX-License-Identifier: GPL-3.0-or-later
"""Add Projector's placement (issue 36): mirrored across the camera's view, or swung around the object."""
import numpy as np

from lapig.lapig_core.multi.placement import added_projector

CENTRE = np.array([0.0, 0.0, 1.0])
CAMERA = np.array([0.0, -3.0, 1.2])  # in front of the object (Blender's front view looks along +Y)


def _front_left(degrees=35.0, distance=3.0, height=1.5):
    a = np.radians(degrees)
    return np.array([-distance * np.sin(a), -distance * np.cos(a), height])


def test_a_projector_on_the_front_left_gets_a_partner_on_the_front_right_aimed_at_the_centre():
    first = _front_left()
    added = added_projector([first], CENTRE, CAMERA)
    assert added.how == "mirrored" and added.side == "right"
    assert np.allclose(added.position, [-first[0], first[1], first[2]])
    assert np.isclose(added.distance, np.linalg.norm(first - CENTRE))
    forward = -added.rotation[:, 2]
    assert np.allclose(forward, (CENTRE - added.position) / added.distance)
    assert np.allclose(added.rotation.T @ added.rotation, np.eye(3), atol=1e-9)
    assert "on its right" in added.sentence("LAPIG Projector 2", "Bust")


def test_a_projector_on_the_cameras_axis_is_swung_around_the_object_instead():
    above = np.array([0.0, -3.0, 2.5])  # above the camera: its mirror image is itself
    added = added_projector([above], CENTRE, CAMERA)
    assert added.how == "swung"
    assert np.linalg.norm(added.position - above) > 1.0
    assert np.isclose(added.position[2], above[2])  # the same height, around the vertical axis


def test_a_third_projector_does_not_land_on_the_second():
    first = _front_left()
    second = added_projector([first], CENTRE, CAMERA).position
    third = added_projector([first, second], CENTRE, CAMERA)
    assert third.how == "swung"
    assert min(np.linalg.norm(third.position - p) for p in (first, second)) > 1.0
