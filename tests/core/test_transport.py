"""Light transport models: thin-lens defocus, vignetting, the indirect pass, the mode's fingerprint."""
import numpy as np
import pytest

from lapig.lapig_core.optics import transport as light
from lapig.lapig_core.optics.transport import FAST, LightTransport


def _edge_blur_radius(profile):
    """Disk radius from an edge profile: its derivative's variance is r^2 / 4 for a disk."""
    lsf = np.clip(np.diff(profile), 0, None)
    x = np.arange(len(lsf))
    mean = (lsf * x).sum() / lsf.sum()
    return 2 * np.sqrt((lsf * (x - mean) ** 2).sum() / lsf.sum())


def test_blur_is_zero_at_the_focus_and_follows_the_thin_lens_off_it():
    r = light.blur_radius_px([2.0, 3.0, 6.0], focus_m=3.0, lens_radius_m=0.01, focal_px=1000)
    assert r[1] == pytest.approx(0.0)
    assert r[0] == pytest.approx(0.01 * (1 / 2 - 1 / 3) * 1000)
    assert r[2] == pytest.approx(0.01 * (1 / 3 - 1 / 6) * 1000)
    assert light.blur_radius_px([np.nan], 3.0, 0.01, 1000)[0] == 0.0  # a pixel that lights nothing


@pytest.mark.parametrize("radius", [1.5, 3.0, 6.0])
def test_defocus_blurs_an_edge_by_the_radius_asked_for(radius):
    frame = np.zeros((64, 64, 3), np.float32)
    frame[32:] = 1.0
    out = light.defocus_frame(frame, np.full((64, 64), radius, np.float32))
    assert _edge_blur_radius(out[:, 32, 0]) == pytest.approx(radius, rel=0.1)
    assert out[:, 32, 0].sum() == pytest.approx(frame[:, 32, 0].sum(), rel=0.05)  # light is kept


def test_defocus_keeps_the_focal_plane_sharp_and_blurs_by_depth():
    rng = np.random.default_rng(0)
    frame = rng.random((48, 96, 3)).astype(np.float32)
    radius = np.tile(np.abs(np.linspace(-4, 4, 96, dtype=np.float32)), (48, 1))  # in focus in the middle
    out = light.defocus_frame(frame, radius)
    assert np.abs(out[:, 47:49] - frame[:, 47:49]).max() < 0.15
    detail = lambda im: np.abs(np.diff(im, axis=0)).mean()
    assert detail(out[:, :10]) < 0.4 * detail(frame[:, :10])
    assert detail(out[:, 40:56]) > 2 * detail(out[:, :10])
    assert np.array_equal(light.defocus_frame(frame, np.zeros((48, 96), np.float32)), frame)


def test_vignetting_is_cos4_off_the_axis_and_can_be_off():
    v = light.vignetting_map(40, 30, half_width_tan=0.4, strength=1.0)
    assert v[15, 20] == pytest.approx(1.0, abs=0.01)
    corner_tan2 = (0.4 * 39 / 40) ** 2 + (0.3 * 29 / 30) ** 2
    assert v[0, 0] == pytest.approx(1 / (1 + corner_tan2) ** 2, rel=1e-3)
    assert np.all(light.vignetting_map(40, 30, 0.4, 0.0) == 1.0)


def test_indirect_pass_cancels_the_direct_light_and_keeps_the_bounce():
    rng = np.random.default_rng(1)
    direct = rng.random((24, 32, 3)).astype(np.float32)  # sharp texture: must cancel exactly
    y, x = np.mgrid[0:24, 0:32]
    bounce = (0.1 + 0.05 * np.sin(x / 8.0))[..., None].repeat(3, -1).astype(np.float32)
    noisy = direct + bounce + 0.02 * rng.standard_normal(direct.shape).astype(np.float32)
    up = light.indirect_from_passes(noisy, direct, (128, 96))
    assert up.shape == (96, 128, 3)
    truth = light.indirect_from_passes(direct + bounce, direct, (128, 96), smooth_px=0)
    assert np.abs(up - truth)[8:-8, 8:-8].mean() < 0.01


def test_the_mode_and_its_settings_change_the_state_a_capture_depends_on():
    realistic = LightTransport()
    assert FAST.state() != realistic.state()
    assert LightTransport(bounces=1).state() != realistic.state()
    assert LightTransport(projector_focus_m=2.0).state() != realistic.state()
    assert FAST.state() == LightTransport(mode="FAST", bounces=7).state()  # fast ignores the rest
    assert "Fast" in FAST.label() and "Realistic" in realistic.label()
    assert not FAST.uses_bounces and not FAST.uses_projector_defocus and not FAST.uses_vignetting
    with pytest.raises(ValueError, match="unknown light transport mode"):
        LightTransport(mode="SLOW")


def test_the_light_passes_put_back_the_texture_the_bounce_light_falls_on():
    import cv2

    h, w = 64, 96
    yy, xx = np.mgrid[0:h, 0:w]
    albedo = np.where(((yy // 3 + xx // 3) % 2)[..., None] == 0, 0.8, 0.2).astype(np.float32) * np.ones(3, np.float32)
    irradiance = (0.05 + 0.1 * xx / w).astype(np.float32)[..., None] * np.ones(3, np.float32)
    bounce_full = albedo * irradiance
    low = (w // 4, h // 4)
    # what a low-resolution render with bounces writes: its Diffuse Indirect pass, and its Combined light
    irradiance_low = cv2.resize(irradiance, low, interpolation=cv2.INTER_AREA)
    direct_low = np.full((h // 4, w // 4, 3), 0.3, np.float32)
    with_bounces_low = direct_low + cv2.resize(bounce_full, low, interpolation=cv2.INTER_AREA)
    passes = light.indirect_from_light_passes(irradiance_low, None, albedo, (w, h), 1.0)
    difference = light.indirect_from_passes(with_bounces_low, direct_low, (w, h), 1.0)
    inner = (slice(8, -8), slice(8, -8))
    error = lambda x: np.abs(x[inner] - bounce_full[inner]).mean() / bounce_full[inner].mean()
    assert error(passes) < 0.05  # the checker the bounce light falls on is back
    assert error(difference) > 0.3  # a low-resolution difference alone smooths it away
    gloss = np.full_like(irradiance_low, 0.01)  # glossy (and other) bounce light is added as it is
    assert np.allclose(light.indirect_from_light_passes(irradiance_low, gloss, albedo, (w, h), 1.0) - passes, 0.01,
                       atol=1e-5)
    with pytest.raises(ValueError, match="albedo pass"):
        light.indirect_from_light_passes(irradiance_low, None, albedo[:32], (w, h), 1.0)
    with pytest.raises(ValueError, match="bounce method"):
        LightTransport(bounce_method="denoise")


def test_the_normal_guide_keeps_each_wall_of_a_corner_to_its_own_bounce_light():
    h, w, scale = 16, 32, 4
    normal_low = np.zeros((h, w, 3), np.float32)
    normal_low[:, : w // 2] = (1, 0, 0)
    normal_low[:, w // 2:] = (0, 1, 0)  # two walls at 90 degrees, the crease in the middle
    light_low = np.where(np.arange(w)[None, :, None] < w // 2, 1.0, 0.1).astype(np.float32) * np.ones((h, 1, 3))
    cover = np.ones((h, w), np.float32)
    normal = np.repeat(np.repeat(normal_low, scale, 0), scale, 1)
    size = (w * scale, h * scale)
    guide = light.NormalGuide(cover, normal_low, normal, size, smooth_px=2.5)
    guided = guide.scale_up(light_low)[..., 0]
    plain = light._smooth_and_scale_up(light_low, size, 2.5, cover)[..., 0]
    beside = (w // 2) * scale  # the first column of the dim wall
    assert guided[:, beside] == pytest.approx(0.1, abs=0.01)  # the bright wall's light stays on it
    assert guided[:, beside - 1] == pytest.approx(1.0, abs=0.01)
    assert plain[:, beside].mean() > 0.4  # a plain blur carries it across the crease
    # a flat surface: the guide is a smooth interpolation that keeps the light's level
    flat = light.NormalGuide(cover, np.tile(np.float32([0, 0, 1]), (h, w, 1)), np.tile(np.float32([0, 0, 1]),
                             (h * scale, w * scale, 1)), size, 2.5)
    assert np.allclose(flat.scale_up(np.full((h, w, 3), 0.3, np.float32)), 0.3, atol=1e-5)
    with pytest.raises(ValueError, match="guide is for"):
        guide.scale_up(light_low[:8])


def test_the_first_order_fit_follows_the_bounce_light_rising_into_a_crease():
    """Next to a crease all of a pixel's neighbours lie on one side: their mean falls short of light
    that rises towards the crease, a fitted plane does not (and keeps a flat light flat)."""
    h, w, scale = 16, 40, 4
    normal_low = np.zeros((h, w, 3), np.float32)
    normal_low[:, : w // 2] = (1, 0, 0)
    normal_low[:, w // 2:] = (0, 1, 0)
    x = np.arange(w, dtype=np.float32)
    ramp = np.where(x < w // 2, 0.2 + 0.02 * x, 0.3)  # the left wall brightens towards the crease
    light_low = np.repeat(ramp[None, :, None], h, 0).repeat(3, -1).astype(np.float32)
    cover = np.ones((h, w), np.float32)
    normal = np.repeat(np.repeat(normal_low, scale, 0), scale, 1)
    size = (w * scale, h * scale)
    mean = light.NormalGuide(cover, normal_low, normal, size, 3.0, first_order=False)
    plane = light.NormalGuide(cover, normal_low, normal, size, 3.0)
    last = w // 2 - 1  # the last low-resolution column before the crease
    truth = 0.2 + 0.02 * last
    by_mean = mean.scale_up(light_low)[h * scale // 2, last * scale + scale // 2, 0]
    by_plane = plane.scale_up(light_low)[h * scale // 2, last * scale + scale // 2, 0]
    assert truth - by_mean > 0.03  # the mean lags the rise by more than a tenth of it
    assert by_plane == pytest.approx(truth, abs=0.005)
    # the ramp also reaches the frame's left edge: nothing is past it, so the plane keeps it there too
    assert plane.scale_up(light_low)[h * scale // 2, scale // 2, 0] == pytest.approx(0.2, abs=0.005)
    right = plane.scale_up(light_low)[:, (w // 2 + 1) * scale:, 0]
    assert np.allclose(right, 0.3, atol=1e-4)  # the flat wall stays flat, and takes nothing across
    with pytest.raises(ValueError, match="bounce light fit"):
        LightTransport(indirect_fit="cubic")


def test_a_small_capture_keeps_a_bounce_pass_of_its_own_size():
    t = LightTransport()
    assert t.indirect_size(480, 360) == (120, 90)
    assert t.indirect_size(160, 120) == (120, 90)
    assert t.indirect_size(96, 72) == (96, 72)
    assert t.indirect_size(1920, 1080) == (480, 270)
