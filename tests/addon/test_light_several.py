"""Light in real units for several projectors (issue 36), without Blender: their maps over the camera's pixels
added, each one's lumens and share named, the dose on the sum, the dose cap one factor for all."""
import importlib
import json

import numpy as np
import pytest

from lapig.lapig_core.optics.projector_model import ProjectorModel
from lapig.lapig_core.photometry import dose
from lapig.lapig_core.photometry.light_passes import ProjectorLightMaps, projector_shares, sum_projector_maps


@pytest.fixture
def lr():
    return importlib.import_module("lapig.lapig_addon.services.light.light_report")


@pytest.fixture
def lj():
    return importlib.import_module("lapig.lapig_addon.services.light.light_joint")


def _maps(white_left, white_right, room=0.0):
    """A projector's light over 8 x 10 camera pixels: `white_left` lux on the left half, `white_right` on the
    right; the room's light where it rendered it; the object everywhere but the last column."""
    white = np.zeros((8, 10))
    white[:, :5], white[:, 5:] = white_left, white_right
    on = np.ones((8, 10), bool)
    on[:, -1] = False
    return ProjectorLightMaps(white, np.full((8, 10), room), np.full((8, 10), 0.5), on, on.copy())


def test_light_adds_over_the_cameras_pixels_and_the_room_counts_once():
    left, right = _maps(300.0, 0.0, room=20.0), _maps(0.0, 100.0)  # the room in the first's maps only
    total = sum_projector_maps([left, right])
    assert total.white_lux[0, 0] == 300 and total.white_lux[0, 7] == 100 and total.ambient_lux.max() == 20
    assert total.on_object.sum() == 8 * 9
    assert projector_shares([left.white_lux, right.white_lux], total.on_object) == pytest.approx([15 / 19, 4 / 19])  # on the object only
    with pytest.raises(ValueError, match="other samples"):
        sum_projector_maps([left, ProjectorLightMaps(np.zeros((4, 4)), 0, 0, np.ones((4, 4), bool),
                                                     np.ones((4, 4), bool))])


def test_two_stacked_projectors_give_twice_the_light_and_half_each(lr, lj):
    model = ProjectorModel()
    plan = lr.LightPlan(lumens=2000, ambient_lux=20)
    one = lr.light_report(plan, _maps(400.0, 400.0, room=20.0), None, model)
    lumens = lj.joint_lumens(plan, [10.0, 10.0], [model, model])
    assert lumens == pytest.approx([2000, 2000])  # a copy of the first has the first's lumens
    two, total, _ = lj.joint_report(plan, [_maps(400.0, 400.0, room=20.0), _maps(400.0, 400.0)], None,
                                      [model, model], ["A", "B"], lumens)
    assert two["white_lux"]["mean"] == pytest.approx(2 * one["white_lux"]["mean"])
    assert two["lumens"] == 4000 and two["light_power_w"] == pytest.approx(2 * one["light_power_w"], rel=1e-3)
    assert two["contrast_ratio"]["median"] > one["contrast_ratio"]["median"]  # brighter against the same room
    assert [p["share"] for p in two["projectors"]] == [0.5, 0.5]
    assert two["projectors_line"] == "A 50% of the light (2,000 lm); B 50% of the light (2,000 lm)"
    json.dumps(two)


def test_each_projector_its_own_lumens_and_look(lr, lj):
    model = ProjectorModel()
    plan = lr.LightPlan(lumens=1000, limit=dose.ConservationLimit("high", schedule=dose.Schedule(10, 200)))
    lumens = lj.joint_lumens(plan, [10.0, 30.0], [model, model])  # the second set three times as bright
    assert lumens == pytest.approx([1000, 3000])
    left, right = _maps(300.0, 0.0), _maps(0.0, 300.0)
    # the left projector shows half white, the right full white
    emitted = [np.full((8, 10), 0.5), np.ones((8, 10))]
    report, total, combined = lj.joint_report(plan, [left, right], emitted, [model, model], ["L", "R"], lumens)
    look = total.white_lux * combined
    assert look[0, 0] == pytest.approx(150) and look[0, 6] == pytest.approx(300)
    assert report["look_lux"]["max"] == pytest.approx(300) and report["look_lux"]["min"] == pytest.approx(150)
    shares = {p["name"]: p["share"] for p in report["projectors"]}
    assert shares["L"] == pytest.approx(150 * 5 / (150 * 5 + 300 * 4), abs=1e-4)  # the look's light on the object
    # the dose on the sum: 300 lux against 50: one factor for every projector's light brings it within
    assert not report["dose"]["within_limit"] and report["dose"]["max_lux"] == pytest.approx(300)
    scale = lj.joint_cap_factor(plan, total, combined, margin=0.0)
    assert scale == pytest.approx(50 / 300, rel=0.01)


def test_one_projector_through_the_joint_path_reads_as_today(lr, lj):
    model = ProjectorModel()
    plan = lr.LightPlan(lumens=2000, ambient_lux=20, limit=dose.ConservationLimit("high"))
    emitted = np.full((8, 10), 0.25)
    today = lr.light_report(plan, _maps(400.0, 320.0, room=20.0), emitted, model)
    several, _, _ = lj.joint_report(plan, [_maps(400.0, 320.0, room=20.0)], [emitted], [model], ["P"], [2000.0])
    for key in ("white_lux", "look_lux", "total_lux", "contrast_ratio", "dose", "lumens", "light_power_w"):
        assert several[key] == today[key], key


def test_the_dose_cap_scales_every_projectors_light_by_one_factor(lr, lj):
    model = ProjectorModel()
    frame = np.full((6, 8, 3), 0.8, np.float32)
    frame[:, :4] = 0.0  # black stays black
    half = lj.scaled_frame(frame, model, 0.5)
    e0, e1 = model.emitted(frame), model.emitted(half)
    lit = frame[..., 0] > 0
    assert np.allclose(e1[lit], 0.5 * e0[lit], rtol=1e-3) and np.all(half <= frame)
    assert np.array_equal(half[~lit], frame[~lit])
    assert np.array_equal(lj.scaled_frame(frame, model, 1.0), np.floor(frame * 65535 + 1e-9) / 65535)
    plan = lr.LightPlan(lumens=1000, ambient_lux=10, limit=dose.ConservationLimit("high", schedule=dose.Schedule(10, 200)))
    _, total, combined = lj.joint_report(plan, [_maps(300.0, 0.0, room=10.0), _maps(0.0, 300.0)], None,
                                           [model, model], ["L", "R"], [1000.0, 1000.0])
    factor = lj.joint_cap_factor(plan, total, combined)
    assert factor == pytest.approx((50 * 0.99 - 10) / 300)  # the brightest point of the sum meets the limit


def test_the_dose_cap_job_of_several_writes_a_limited_result_of_its_own(lr, lj, tmp_path):
    from lapig.lapig_core.export.result_files import write_new_result
    from lapig.lapig_core.multi.result_files import projector_images

    model = ProjectorModel(width=8, height=6)
    frames = [np.full((6, 8, 3), 0.9, np.float32), np.full((6, 8, 3), 0.6, np.float32)]
    folder = write_new_result(tmp_path, "look", {"look": np.full((8, 10, 3), 0.5, np.float32),
                                                 "projector_1": frames[0], "projector_2": frames[1]},
                              {"prompt": "p", "summary_line": "look", "multi": {"count": 2},
                               "projectors": [{"name": "L", "image": "projector_1.png", "size": [8, 6]},
                                              {"name": "R", "image": "projector_2.png", "size": [8, 6]}]})

    class Light:
        strategy = importlib.import_module("lapig.lapig_addon.services.state").JOINT
        models, names, lumens, target_name = [model, model], ["L", "R"], [1000.0, 1000.0], "Bust"

        def steps(self, shown, start=0.0, end=1.0):
            assert len(shown) == 2
            yield 0.5, "rendering"
            return [_maps(300.0, 0.0, room=10.0), _maps(0.0, 300.0)], [np.ones((8, 10)), np.ones((8, 10))]

    plan = lr.LightPlan(lumens=1000, ambient_lux=10, limit=dose.ConservationLimit("high", schedule=dose.Schedule(10, 200)))
    from types import SimpleNamespace

    state = importlib.import_module("lapig.lapig_addon.services.state")
    store = SimpleNamespace(read=state.SceneState, export_settings=lambda: SimpleNamespace(bit_depth=16))
    job = importlib.import_module("lapig.lapig_addon.services.light.dose_cap").DoseCapJob(
        SimpleNamespace(store=store, devices=None), plan, Light(), str(folder), record=False)
    assert job.run() == "DONE", job.error
    out = job.result
    assert out["folder"] != str(folder) and out["scale"] == pytest.approx((50 * 0.99 - 10) / 300)
    assert out["max_lux_before"] == pytest.approx(310) and out["predicted_max_lux"] <= 50
    capped = [image for _, image in projector_images(out["folder"])]
    for before, after in zip(frames, capped):  # both projectors dimmed by the same factor of light
        ratio = model.emitted(after)[0, 0, 0] / model.emitted(before)[0, 0, 0]
        assert ratio == pytest.approx(out["scale"], rel=0.01)
    saved = json.loads(open(f"{out['folder']}/result.json").read())
    assert saved["dose_cap"]["scale"] == pytest.approx(out["scale"], abs=1e-4)
    assert "every projector's light x0.13" in saved["summary_line"]
    assert [p["image"] for p in saved["projectors"]] == ["projector_1.png", "projector_2.png"]
    assert json.loads(open(f"{folder}/result.json").read())["summary_line"] == "look"  # the free look stays
