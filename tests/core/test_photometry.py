"""Light in real units: the lumens <-> watts conversion, the planning formulas, presets, the dose guard."""
import math

import numpy as np
import pytest

from lapig.lapig_core.optics.projector_model import ProjectorModel
from lapig.lapig_core.photometry import dose, light_maps, presets, projector_table, units


def _intensity_cd(watts):
    """Luminous intensity (cd) of a Blender spot of `watts` towards a white pixel: 683 lm/W over 4 pi sr."""
    return units.LUMENS_PER_WATT * watts / (4 * math.pi)


def _grid_illuminance(model, watts, n=400):
    """Illuminance (lux) on the plane at distance 1 over the image, from the pinhole's physics:
    E = I cos^3 / d^2 with I = 683 W / 4pi per unit emitted light; and each cell's area."""
    x0, x1, y0, y1 = units._bounds(model)
    xs = x0 + (np.arange(n) + 0.5) / n * (x1 - x0)
    ys = y0 + (np.arange(n) + 0.5) / n * (y1 - y0)
    x, y = np.meshgrid(xs, ys)
    e = _intensity_cd(watts) * (1 + x * x + y * y) ** -1.5
    return e, (x1 - x0) * (y1 - y0) / n ** 2


@pytest.mark.parametrize("model", [ProjectorModel(), ProjectorModel(1920, 1080, 0.8),
                                   ProjectorModel(1280, 800, 2.0, shift_x=0.2, shift_y=-0.4)])
def test_ansi_rule_gives_the_lumens_as_a_meter_on_nine_points_reads_them(model):
    watts = units.lumens_to_watts(3000, model)
    x = units.ansi_points(model)
    nine = _intensity_cd(watts) * (1 + x[:, 0] ** 2 + x[:, 1] ** 2) ** -1.5  # lux at unit distance
    assert nine.mean() * units.image_area_at_unit_distance(model) == pytest.approx(3000, rel=1e-9)
    assert units.watts_to_lumens(watts, model) == pytest.approx(3000)


@pytest.mark.parametrize("model", [ProjectorModel(), ProjectorModel(640, 480, 0.6, shift_y=0.5)])
def test_flux_rule_puts_every_lumen_into_the_frustum(model):
    watts = units.lumens_to_watts(2000, model, rule="flux")
    e, cell = _grid_illuminance(model, watts)
    # the flux through the image at unit distance: illuminance x area, on the plane
    assert (e * cell).sum() == pytest.approx(2000, rel=1e-4)
    # and the two rules differ by the nine points' sampling of the cos^3 falloff only (about 1%)
    ratio = units.lumens_to_watts(2000, model) / watts
    assert 0.95 < ratio < 1.05


def test_frustum_solid_angle_of_a_cube_face():
    # throw 0.5 and a square frame: the image spans x, y in [-1, 1] at unit distance, a cube's face
    assert units.frustum_solid_angle(ProjectorModel(600, 600, 0.5)) == pytest.approx(4 * math.pi / 6)
    # lens shift moves the frame off the axis: less solid angle for the same image
    shifted = ProjectorModel(600, 600, 0.5, shift_x=0.5)
    assert units.frustum_solid_angle(shifted) < 4 * math.pi / 6


def test_white_mean_divides_the_power():
    m = ProjectorModel()
    assert units.lumens_to_watts(1000, m, white_mean=0.5) == pytest.approx(2 * units.lumens_to_watts(1000, m))


@pytest.mark.parametrize("bad", [0, -10, float("nan"), float("inf")])
def test_lumens_must_be_positive(bad):
    with pytest.raises(units.LightUnitError, match="more than 0 lumens"):
        units.lumens_to_watts(bad, ProjectorModel())


def test_negative_lux_is_refused():
    with pytest.raises(units.LightUnitError, match="0 lux or more"):
        units.check_lux(-1)
    with pytest.raises(units.LightUnitError):
        units.world_strength_for_lux(-5)


def test_render_values_to_lux_and_luminance():
    # a Sun of strength S W/m2 on albedo rho renders rho S / pi: 683 S lux
    s, rho = 0.2, 0.8
    assert units.lux_from_radiance(rho * s / math.pi, rho) == pytest.approx(683 * s)
    assert units.lux_from_diffuse_direct(np.full((2, 2, 3), s / math.pi)) == pytest.approx(683 * s)
    assert units.luminance_cd_m2(0.8, 100.0) == pytest.approx(80 / math.pi)
    assert units.sun_strength_for_lux(683) == pytest.approx(1.0)
    assert units.world_strength_for_lux(683 * math.pi) == pytest.approx(1.0)


def test_contrast_formulas_invert_each_other():
    assert units.black_level_from_contrast(2000) == pytest.approx(1 / 2000)
    with pytest.raises(units.LightUnitError):
        units.black_level_from_contrast(1)
    for c in (None, 3000.0):
        white = units.white_lux_for_contrast(5, 80, c)
        assert units.contrast_ratio(white, 80, c) == pytest.approx(5)
        room = units.ambient_lux_for_contrast(10, 1000, c)
        assert units.contrast_ratio(1000, room, c) == pytest.approx(10)
    assert units.white_lux_for_contrast(5, 80) == pytest.approx(320)  # NOTES: 80 lux needs ~400 for a margin
    assert units.white_lux_for_contrast(10, 50, projector_contrast=8) == math.inf  # the projector cannot


def test_planning_illuminance_follows_the_cos_law():
    assert units.planning_illuminance(3000, 2.0) == pytest.approx(1500)
    assert units.planning_illuminance(3000, 2.0, 60) == pytest.approx(750)


# -- presets --------------------------------------------------------------------------------------------
def test_presets_cover_the_range_with_sources():
    all_ = presets.all_presets()
    assert len(all_) >= 6
    kinds = " ".join(p.kind for p in all_)
    for word in ("LED", "3LCD", "laser", "short throw", "lens shift"):
        assert word in kinds
    for p in all_:
        assert p.source and p.ansi_lumens > 0 and p.contrast > 1 and p.throw_ratio[0] > 0
        assert set(p.confirmed) | set(p.unconfirmed) == set(presets.FIGURES)
        assert bool(p.confirmed) == bool(p.confirmed_by)
    assert any(p.lens_shift_y[1] > 0 for p in all_)


def test_unknown_preset_names_the_nearest():
    with pytest.raises(presets.PresetError, match="did you mean epson-eb-pu1007b"):
        presets.preset("epson-eb-pu1007")


def test_a_malformed_presets_file_is_refused(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('[[projector]]\nid = "x"\nmaker = "M"\nmodel = "X"\nkind = "k"\nsource = "s"\n'
                    'ansi_lumens = 0\ncontrast = 100\n')
    with pytest.raises(presets.PresetError, match="ansi_lumens"):
        presets.load_presets(path)


# -- dose -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("hours,days,match", [(25, 300, "at most 24"), (0, 300, "more than 0"),
                                              (8, 400, "days per year")])
def test_impossible_schedules_are_refused(hours, days, match):
    limit = dose.ConservationLimit("high", schedule=dose.Schedule(hours, days))
    assert match in limit.problem()
    with pytest.raises(dose.DoseError, match=match):
        limit.check()


def test_categories_and_custom_limits():
    assert dose.ConservationLimit("high").limit_lux == 50
    assert dose.ConservationLimit("moderate").limit_lux == 200
    custom = dose.ConservationLimit("custom", 80, dose.Schedule(10, 100))
    assert custom.limit_lux == 80 and custom.yearly_budget_lux_h == 80_000
    assert "more than 0 lux" in dose.ConservationLimit("custom", -1).problem()
    assert "unknown conservation category" in dose.ConservationLimit("bright").problem()


def test_dose_figures_on_a_region():
    lux = np.array([[10.0, 60.0], [40.0, 500.0]])
    region = np.array([[True, True], [True, False]])
    limit = dose.ConservationLimit("high", schedule=dose.Schedule(8, 300))
    f = dose.dose_figures(lux, region, limit)
    assert f["max_lux"] == 60 and f["mean_lux"] == pytest.approx(36.67, abs=0.01)
    assert f["lux_hours_per_year_max"] == 60 * 2400 and not f["within_limit"]
    assert f["share_over_limit"] == pytest.approx(1 / 3, abs=1e-3)
    with pytest.raises(dose.DoseError, match="no faces"):
        dose.dose_figures(lux, np.zeros((2, 2), bool), limit)


def test_the_cap_keeps_the_quantised_frame_under_the_limit():
    rng = np.random.default_rng(1)
    model = ProjectorModel(64, 48, black_level=0.002)
    white = rng.uniform(100, 900, (48, 64))
    ambient = np.full((48, 64), 5.0)
    region = np.zeros((48, 64), bool)
    region[10:40, 8:50] = True
    frame = np.round(rng.uniform(0, 1, (48, 64, 3)) * 255) / 255  # a quantised 8-bit frame
    cap, unmet = dose.emitted_cap(white, ambient, region, 50.0, model.black_level)
    capped = dose.cap_input(frame, cap, model.gamma, model.black_level, 8)
    assert np.allclose(np.round(capped * 255), capped * 255)  # on the 8-bit steps
    lux = white * model.emitted(capped).max(-1) + ambient
    assert lux[region].max() <= 50.0 + 1e-9
    assert np.array_equal(capped[~region], frame[~region])  # off the region nothing changes
    assert (capped <= frame + 1e-12).all()
    assert unmet["room_light_over_limit_share"] == 0
    _, unmet = dose.emitted_cap(white, np.full((48, 64), 80.0), region, 50.0)
    assert unmet["room_light_over_limit_share"] == 1.0


# -- the summary and maps --------------------------------------------------------------------------------
def test_summary_warns_below_5_to_1_and_its_fix_reaches_it():
    white = np.full((8, 8), 200.0)
    white[:, :4] = 300.0
    valid = np.ones((8, 8), bool)
    s = light_maps.light_summary(white, 100.0, 0.6, np.ones((8, 8)), valid, lumens=500)
    assert s["contrast_below_5_share"] == 1.0 and "below 5:1" in s["warning"]
    fix = s["fixes"]["lumens_for_5_to_1"]
    assert s["fixes"]["lumens_for_5_to_1_with_headroom"] == pytest.approx(fix / 0.7, abs=1)
    brighter = white * fix / 500
    assert units.contrast_ratio(brighter, 100.0).min() >= 5 - 0.05
    dim = s["fixes"]["ambient_lux_for_5_to_1"]
    assert units.contrast_ratio(white, dim).min() >= 5 - 0.05
    ok = light_maps.light_summary(white * 10, 100.0, 0.6, np.ones((8, 8)), valid, lumens=5000)
    assert ok["warning"] == "" and ok["luminance_cd_m2"]["max"] == pytest.approx(0.6 * 3100 / math.pi, abs=0.01)


def test_colour_maps_mark_the_planning_bands():
    c = np.array([[2.0, 7.0, 20.0]])
    rgb = light_maps.contrast_colour_map(c, np.ones_like(c, bool))
    assert rgb[0, 0, 0] > rgb[0, 0, 1] and rgb[0, 2, 1] > rgb[0, 2, 0]  # red below 5, green above 10
    lux = light_maps.lux_colour_map(np.array([[1.0, 100.0, 10000.0]]), np.ones((1, 3), bool))
    assert lux[0, 0].sum() < lux[0, 1].sum() < lux[0, 2].sum()


def test_projector_table_csv(tmp_path):
    row = projector_table.ProjectorRow("P1", "Epson", "EB-G5350", (1024, 768), 5000, 1.5, 0.0, 0.25,
                                       (0, -2.8, 1), (90, 0, 0), 2.82, 1879.5)
    path = projector_table.write_projector_table(tmp_path / "t.csv", [row])
    lines = path.read_text().splitlines()
    assert lines[0].split(",") == list(projector_table.COLUMNS)
    assert lines[1].startswith("P1,Epson,EB-G5350,1024,768,5000,1.5,0.0,25.0,")
    assert not list(tmp_path.glob("*.tmp*"))


def test_dropout_repair_raises_lone_dips_and_keeps_shadow_edges():
    lux = np.full((6, 8), 100.0)
    lux[2, 3] = 75.0  # one of four samples lost
    lux[:, 6:] = 5.0  # a real shadow
    fixed = light_maps.repair_dropouts(lux)
    assert fixed[2, 3] == 100.0
    assert np.array_equal(fixed[:, 5:], lux[:, 5:]) and (fixed >= lux).all()


def test_a_dark_room_gives_finite_figures():
    white = np.array([[0.0, 300.0]])
    s = light_maps.light_summary(white, 0.0, 0.5, np.ones((1, 2)), np.ones((1, 2), bool), lumens=1000)
    assert s["contrast_ratio"]["min"] == 1.0 and s["contrast_ratio"]["max"] == light_maps.MAX_CONTRAST
    import json
    json.dumps(s, allow_nan=False)


def test_the_luminance_cap_holds_the_lux_with_less_change():
    rng = np.random.default_rng(2)
    model = ProjectorModel(32, 24, black_level=0.002)
    white = rng.uniform(100, 900, (24, 32))
    region = np.zeros((24, 32), bool)
    region[4:20, 4:28] = True
    frame = np.round(rng.uniform(0, 1, (24, 32, 3)) * 255) / 255
    cap, _ = dose.emitted_cap(white, 5.0, region, 50.0, model.black_level)
    lum = dose.cap_input_luminance(frame, cap, model.gamma, model.black_level, 8)
    chan = dose.cap_input(frame, cap, model.gamma, model.black_level, 8)
    y = model.emitted(lum) @ units.LUMA
    assert (white * y + 5.0)[region].max() <= 50.0 + 1e-9
    assert np.allclose(np.round(lum * 255), lum * 255) and np.array_equal(lum[~region], frame[~region])
    assert (lum <= frame + 1e-12).all()
    change = lambda f: np.square(model.emitted(f) - model.emitted(frame)).sum()  # noqa: E731
    assert change(lum) < change(chan)
