import numpy as np
import pytest

from lapig.lapig_core.optics.placement import place_rig


def _grid_panel(width=2.0, height=1.5, normal_y=-1.0):
    xs, zs = np.meshgrid(np.linspace(-width / 2, width / 2, 11), np.linspace(-height / 2, height / 2, 9))
    pts = np.stack([xs.ravel(), np.zeros(xs.size), zs.ravel() + 1.0], axis=1)
    normals = np.tile([0.0, normal_y, 0.0], (len(pts), 1))
    return pts, normals


def _frame_corners(pose, throw, aspect, distance_to_plane):
    right, up, back = pose.rotation.T
    half_w = distance_to_plane / throw / 2
    return [pose.location - back * distance_to_plane + sx * half_w * right + sy * half_w / aspect * up
            for sx in (-1, 1) for sy in (-1, 1)]


def test_wall_is_filled_by_the_projector_frame():
    pts, normals = _grid_panel()
    rig = place_rig(pts, normals, throw_ratio=1.5, aspect=4 / 3)
    assert rig.planar
    assert rig.projector.location[1] < -0.5  # in front of the wall, on the side its normal faces
    dist = -rig.projector.location[1]
    for c in _frame_corners(rig.projector, 1.5, 4 / 3, dist):
        assert abs(c[0]) <= 1.0 + 1e-6 and abs(c[2] - 1.0) <= 0.75 + 1e-6  # frame inside the wall
    assert _frame_corners(rig.projector, 1.5, 4 / 3, dist)[3][0] > 0.85  # and nearly as wide as it


def test_back_facing_panel_is_seen_from_its_front():
    pts, normals = _grid_panel(normal_y=1.0)
    rig = place_rig(pts, normals)
    assert rig.projector.location[1] > 0.5


def test_solid_object_fits_and_camera_sees_every_vertex():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(2000, 3)) * [0.4, 0.4, 0.8] + [0, 0, 1]
    rig = place_rig(pts, throw_ratio=1.5, camera_aspect=4 / 3)
    assert not rig.planar
    local = (pts - rig.camera.location) @ rig.camera.rotation
    tan_half_x = rig.sensor_width_mm / 2 / rig.camera_lens_mm
    assert np.all(-local[:, 2] > 0)
    assert np.all(np.abs(local[:, 0] / -local[:, 2]) <= tan_half_x)
    assert np.all(np.abs(local[:, 1] / -local[:, 2]) <= tan_half_x * 3 / 4)
    # camera beside the projector, like a real rig
    assert 0.1 * rig.distance < np.linalg.norm(rig.camera.location - rig.projector.location) < 0.5 * rig.distance


def test_degenerate_objects_are_refused():
    with pytest.raises(ValueError, match="three vertices"):
        place_rig(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="no size"):
        place_rig(np.zeros((10, 3)))
