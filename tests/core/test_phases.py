"""PhaseTimes: where a job's seconds went."""
import time

from lapig.lapig_core.common.phases import PhaseTimes


def test_phases_add_up_in_the_order_they_first_ran():
    phases = PhaseTimes()
    with phases.timing("fit"):
        time.sleep(0.01)
    phases.add("steps", 1.5)
    phases.add("steps", 0.25)
    phases.add("setup", -0.001)  # a difference of clocks below zero is nothing, not a negative phase
    assert list(phases) == ["fit", "steps", "setup"]
    assert 0.009 <= phases["fit"] < 1.0 and phases["steps"] == 1.75 and phases["setup"] == 0.0
    assert phases.rounded() == {"fit": round(phases["fit"], 2), "steps": 1.75, "setup": 0.0}


def test_a_phase_that_raises_is_still_timed():
    phases = PhaseTimes()
    try:
        with phases.timing("render"):
            raise RuntimeError("the rig failed")
    except RuntimeError:
        pass
    assert "render" in phases
