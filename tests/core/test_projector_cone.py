import math

import numpy as np
import pytest

from lapig.lapig_core.optics.projector_cone import CONE_MARGIN, corner_half_angle, reach, spot_size
from lapig.lapig_core.optics.projector_model import ProjectorModel


def test_a_centred_lens_reaches_its_frame_diagonal():
    model = ProjectorModel(width=800, height=600, throw_ratio=1.5)
    half_diagonal = math.hypot(0.5 / 1.5, 0.5 / (1.5 * 800 / 600))
    assert corner_half_angle(model) == pytest.approx(math.atan(half_diagonal))
    assert spot_size(model) == pytest.approx(2 * (math.atan(half_diagonal) + CONE_MARGIN))


@pytest.mark.parametrize("throw,shift_x,shift_y", [(1.5, 0.0, 0.0), (0.5, 0.2, -0.3), (2.0, -0.4, 0.5),
                                                    (0.3, 0.0, 0.6)])
def test_every_frame_edge_ray_is_inside_the_cone_with_the_margin(throw, shift_x, shift_y):
    model = ProjectorModel(width=640, height=400, throw_ratio=throw, shift_x=shift_x, shift_y=shift_y)
    w, h = model.width, model.height
    edge = np.concatenate([np.stack([np.linspace(-0.5, w - 0.5, 50), np.full(50, y)], 1) for y in (-0.5, h - 0.5)]
                          + [np.stack([np.full(50, x), np.linspace(-0.5, h - 0.5, 50)], 1) for x in (-0.5, w - 0.5)])
    directions = model.pixel_to_direction(edge)
    off_axis = np.arccos(np.clip(-directions[:, 2], -1, 1))
    assert off_axis.max() == pytest.approx(corner_half_angle(model), abs=1e-9)  # a corner is the farthest
    assert spot_size(model) / 2 - off_axis.max() == pytest.approx(CONE_MARGIN, abs=1e-9) or \
        spot_size(model) == pytest.approx(math.pi * 0.999)


def test_a_frame_wider_than_a_half_space_keeps_the_widest_spot():
    model = ProjectorModel(throw_ratio=0.05, shift_x=3.0)
    assert spot_size(model) == pytest.approx(math.pi * 0.999)


def test_the_cone_is_drawn_past_the_farthest_corner():
    corners = np.array([[0, 0, -2], [1, 1, -3], [-1, 0, -2.5]], float)
    assert reach((0, 0, 0), corners) == pytest.approx(math.sqrt(11) * 1.1)
