# SPDX-License-Identifier: GPL-3.0-or-later
"""The schedule: frame counts, keys, holds that repeat one key, periodic motion."""
from lapig.lapig_core.show.model import Look, Motion, Show, Transition
from lapig.lapig_core.show.schedule import schedule_of


def test_frame_counts_and_keys_of_holds_and_transitions():
    show = Show([Look("/a", hold_s=1.0), Look("/b", hold_s=0.5), Look("/c", hold_s=1.0)],
                [Transition("dissolve", 0.5), Transition("morph", 0.25)], fps=8)
    sched = schedule_of(show)
    assert sched.total_frames == round(3.25 * 8) == 26
    keys = sched.keys()
    assert keys[:8] == [("hold", 0, 0.0)] * 8
    dissolve = keys[8:12]
    assert [k[:3] for k in dissolve] == [("dissolve", 0, 1)] * 4
    assert [k[3] for k in dissolve] == [0.2, 0.4, 0.6, 0.8]
    assert keys[12:16] == [("hold", 1, 0.0)] * 4
    assert [k[:3] for k in keys[16:18]] == [("morph", 1, 2)] * 2
    assert keys[18:] == [("hold", 2, 0.0)] * 8
    assert len(set(keys)) == 3 + 4 + 2  # holds: one key each


def test_moving_look_keys_repeat_with_its_period():
    show = Show([Look("/a", hold_s=2.0, motion=Motion("pulse", 0.5, period_s=0.5))], [], fps=10)
    sched = schedule_of(show)
    keys = sched.keys()
    assert sched.total_frames == 20
    assert keys[0] == ("moving", 0, 0.0)
    assert keys[1] == ("moving", 0, 0.1)
    assert keys[5] == keys[0] and keys[7] == keys[2]  # one period is 5 frames
    assert len(set(keys)) == 5


def test_zero_length_transition_takes_no_frames_and_rounding_keeps_the_total():
    show = Show([Look("/a", hold_s=1 / 3), Look("/b", hold_s=1 / 3)], [Transition("dissolve", 0.0)], fps=30)
    sched = schedule_of(show)
    assert sched.total_frames == 20
    assert {k[0] for k in sched.keys()} == {"hold"}
    assert sum(s.frames for s in sched.segments) == 20
