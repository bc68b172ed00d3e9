# SPDX-License-Identifier: GPL-3.0-or-later
"""The show's data: validation with one clear line, and the JSON round trip."""
import json

import pytest

from lapig.lapig_core.show import model
from lapig.lapig_core.show.model import Look, Motion, Show, ShowError, Transition


def _show(**kw):
    looks = kw.pop("looks", [Look("/r/a", "stained glass", hold_s=1.0),
                             Look("/r/b", "ink", seed=3, hold_s=2.0, motion=Motion("drift", 0.5, 2.0))])
    transitions = kw.pop("transitions", [Transition("morph", 0.5)])
    return Show(looks, transitions, **kw)


def test_a_good_show_round_trips_as_plain_json():
    show = _show(fps=24)
    text = json.dumps(show.validate().to_dict())
    again = Show.from_dict(json.loads(text))
    assert again == show
    assert again.to_dict()["seconds"] == pytest.approx(3.5)


@pytest.mark.parametrize("change, words", [
    (dict(fps=0), "frame rate must be more than 0"),
    (dict(fps=-5), "frame rate must be more than 0"),
    (dict(fps="fast"), "frame rate must be a number"),
    (dict(looks=[], transitions=[]), "no looks"),
    (dict(looks=[Look("/r/a", hold_s=-1.0)], transitions=[]), "look 1: the hold must not be negative"),
    (dict(transitions=[Transition("wipe", 1.0)]), "unknown transition 'wipe'"),
    (dict(transitions=[Transition("dissolve", -0.5)]), "its time must not be negative"),
    (dict(transitions=[]), "needs 1 transitions"),
    (dict(looks=[Look("/r/a", motion=Motion("spin"))], transitions=[]), "unknown motion 'spin'"),
    (dict(looks=[Look("/r/a", motion=Motion("pulse", period_s=0))], transitions=[]), "period must be more than 0"),
    (dict(looks=[Look("/r/a", motion=Motion("pulse", amount=2))], transitions=[]), "amount must be between 0 and 1"),
    (dict(looks=[Look("/r/a", hold_s=0.0)], transitions=[]), "less than one frame"),
])
def test_bad_shows_get_one_clear_line(change, words):
    with pytest.raises(ShowError) as info:
        _show(**change).validate()
    assert words in str(info.value)
    assert "\n" not in str(info.value)
    assert isinstance(info.value, ValueError)


def test_malformed_data_is_refused_not_run():
    with pytest.raises(ShowError, match="malformed"):
        Show.from_dict({"fps": 30, "looks": [{"prompt": "no result key"}], "transitions": []})
    with pytest.raises(ShowError, match="JSON object"):
        Show.from_dict(["not", "a", "show"])
    assert set(model.MOTION_PRESETS) == {"drift", "rise", "pulse", "colour_cycle", "world"}
