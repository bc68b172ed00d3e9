"""tools/bench/show_flicker: the flicker split by the reach, the clipped targets and the affine fit (bench show)."""
import numpy as np
import pytest

from lapig.tools.bench.show_flicker import affine_fitted, clipped, flicker_split, out_of_reach


def _frames(n=4, size=(8, 10)):
    rng = np.random.default_rng(0)
    return [rng.uniform(0.2, 0.8, (*size, 3)).astype(np.float32) for _ in range(n)]


def test_a_perfect_capture_does_not_flicker_and_a_lagging_one_does():
    targets = _frames()
    valid = np.ones(targets[0].shape[:2], bool)
    reach = (np.zeros_like(targets[0]), np.ones_like(targets[0]))
    perfect = flicker_split({i: (t, t, valid) for i, t in enumerate(targets)}, [0, 1, 2, 3], reach)
    assert perfect["flicker"] == 0.0 and perfect["out_of_reach_pixels"] == 0.0
    # a capture that shows half of every change: the flicker is half the change
    half = {i: (0.5 * t, t, valid) for i, t in enumerate(targets)}
    assert flicker_split(half, [0, 1, 2, 3], reach)["flicker"] == pytest.approx(0.5, rel=1e-5)


def test_the_clipped_targets_flicker_only_out_of_reach():
    targets = _frames()
    valid = np.ones(targets[0].shape[:2], bool)
    lo = np.full_like(targets[0], 0.1)
    hi = np.full_like(targets[0], 0.9)
    hi[:, :5] = 0.4  # the left half of the surface reaches less than the look asks
    split = flicker_split(clipped({i: (t, t, valid) for i, t in enumerate(targets)}, (lo, hi)), [0, 1, 2, 3],
                          (lo, hi))
    assert split["in_reach"] == pytest.approx(0.0, abs=1e-7)
    assert split["out_of_reach"] > 0.1 and split["out_of_reach_error_share"] == pytest.approx(1.0)
    assert 0.2 < split["out_of_reach_pixels"] <= 0.5
    assert out_of_reach(targets[0], lo, hi)[:, 5:].sum() == 0


def test_the_affine_fit_takes_out_a_cameras_gain_and_offset_only():
    targets = _frames()
    valid = np.ones(targets[0].shape[:2], bool)
    seen = {i: (0.6 * t + 0.05, t, valid) for i, t in enumerate(targets)}
    fitted = affine_fitted(seen)
    assert all(np.allclose(c, t, atol=1e-5) for c, t, _ in fitted.values())
    reach = (np.zeros_like(targets[0]), np.ones_like(targets[0]))
    assert flicker_split(seen, [0, 1, 2, 3], reach)["flicker"] == pytest.approx(0.4, rel=1e-4)
    # a per-pixel shading is left in (compensation would take it out; the fit does not)
    shade = np.linspace(0.5, 1.0, targets[0].shape[1], dtype=np.float32)[None, :, None]
    shaded = affine_fitted({i: (shade * t, t, valid) for i, t in enumerate(targets)})
    assert flicker_split(shaded, [0, 1, 2, 3], reach)["flicker"] > 0.05
