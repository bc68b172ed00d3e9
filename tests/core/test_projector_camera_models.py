import numpy as np
import pytest

from lapig.lapig_core.optics.camera_model import CameraResponse, auto_exposure_stops, clipped_fraction
from lapig.lapig_core.optics.projector_model import ProjectorModel, frame_from_working_image


def test_pixel_ray_round_trip_with_lens_shift():
    model = ProjectorModel(800, 600, throw_ratio=1.3, shift_x=0.1, shift_y=-0.2)
    xy = np.array([[0.0, 0.0], [799.0, 599.0], [400.3, 123.7]])
    dirs = model.pixel_to_direction(xy)
    back = model.uv_to_pixel(model.directions_to_uv(dirs))
    np.testing.assert_allclose(back, xy, atol=1e-9)


def test_throw_ratio_sets_image_width_at_distance():
    model = ProjectorModel(800, 600, throw_ratio=2.0)
    # at 4 m a 2.0 throw ratio gives a 2 m wide image: the frame edges are at x = +-1 m
    uv = model.directions_to_uv(np.array([[-1.0, 0.0, -4.0], [1.0, 0.0, -4.0]]))
    np.testing.assert_allclose(uv[:, 0], [0.0, 1.0])
    assert np.isnan(model.directions_to_uv(np.array([0.0, 0.0, 1.0]))).all()  # behind


def test_emitted_light_gamma_black_level_and_8bit_lookup():
    model = ProjectorModel(gamma=2.0, black_level=0.01)
    assert model.emitted(np.array(0.0)) == pytest.approx(0.01)
    assert model.emitted(np.array(1.0)) == pytest.approx(1.0)
    assert model.emitted(np.array(0.5)) == pytest.approx(0.01 + 0.99 * 0.25)
    img = np.random.default_rng(0).random((8, 8, 3)).astype(np.float32)
    np.testing.assert_allclose(model.emitted_8bit(img), model.emitted(np.round(img * 255) / 255), atol=1e-6)


@pytest.mark.parametrize("kwargs", [dict(width=1), dict(throw_ratio=0), dict(black_level=1.0), dict(gamma=-1)])
def test_bad_projector_settings_are_refused(kwargs):
    with pytest.raises(ValueError):
        ProjectorModel(**kwargs)


def test_working_frame_fills_the_native_frame():
    frame = frame_from_working_image(np.ones((48, 64, 3)), 800, 600)
    assert frame.shape == (600, 800, 3)
    assert frame.min() == 1


def test_camera_response_is_monotonic_and_invertible():
    cam = CameraResponse(gamma=2.2, toe=0.01)
    x = np.linspace(0, 1, 101)
    y = cam.curve(x)
    assert y[0] == pytest.approx(0) and y[-1] == pytest.approx(1)
    assert np.all(np.diff(y) > 0)
    np.testing.assert_allclose(cam.inverse(y), x, atol=1e-9)
    assert y[10] > 0.2  # a real camera's encoding lifts the shadows well above linear


def test_capture_quantises_to_8bit_with_exposure_and_noise():
    cam = CameraResponse(noise_std=0.0, exposure_stops=1.0)
    out = cam.capture(np.full((4, 4, 3), 0.25, np.float32))
    assert out.dtype == np.uint8
    assert np.all(out == np.round(cam.curve(0.5) * 255))
    noisy = CameraResponse(noise_std=0.02).capture(np.full((64, 64, 3), 0.25, np.float32),
                                                  np.random.default_rng(1))
    assert noisy.std() > 0


def test_auto_exposure_keeps_white_below_clipping():
    white = np.random.default_rng(0).uniform(0.5, 3.0, (32, 32, 3)).astype(np.float32)
    stops = auto_exposure_stops(white)
    cap = CameraResponse(noise_std=0, exposure_stops=stops).capture(white)
    assert clipped_fraction(cap) < 0.01
    with pytest.raises(ValueError, match="lights nothing"):
        auto_exposure_stops(np.zeros((4, 4, 3)))
