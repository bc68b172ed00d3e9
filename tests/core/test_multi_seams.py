# SPDX-License-Identifier: GPL-3.0-or-later
"""bench multi's seam and overlap figures (tools/bench/seams) on hand-made two-projector layouts."""
import math

import numpy as np
import pytest

from lapig.tools.bench.seams import blend_edges, near_edges, psnr_on, seam_ratio, white_uniformity_pct

H, W = 40, 100


def _side_by_side(overlap=(45, 55)):
    """Projector 1 reaches columns < overlap[1], projector 2 columns >= overlap[0]."""
    r = np.zeros((2, H, W), bool)
    r[0, :, :overlap[1]] = True
    r[1, :, overlap[0]:] = True
    return r


def test_blend_edges_are_where_one_reach_ends_inside_another():
    edge = blend_edges(_side_by_side())
    cols = np.flatnonzero(edge.any(axis=0))
    assert set(cols) == {44, 45, 54, 55}  # both sides of each hand-over, nothing at the image's borders
    one = np.zeros((1, H, W), bool)
    one[0, :, 10:90] = True
    assert not blend_edges(one).any()  # one projector hands over to nobody


def test_seam_ratio_is_one_for_even_error_and_grows_with_an_error_at_the_edges():
    r = _side_by_side()
    assert seam_ratio(np.full((H, W, 3), 0.02), r) == pytest.approx(1.0)
    err = np.full((H, W), 0.02)
    err[:, 40:50] = 0.06  # a bright band at the first hand-over
    ratio = seam_ratio(err, r, band_px=8)
    assert ratio > 1.15
    near = near_edges(r, band_px=8)
    assert near[:, 44].all() and not near[:, 20].any() and near[:, 62].all() and not near[:, 64].any()
    assert math.isnan(seam_ratio(err, np.ones((1, H, W), bool)))  # no edge: no figure


def test_white_uniformity_compares_the_overlap_with_each_side_in_linear_light():
    r = _side_by_side()
    white = np.full((H, W, 3), 0.7)
    assert white_uniformity_pct(white, r)["pct"] == pytest.approx(0.0)
    white[:, 45:55] = 0.7 * 2 ** (1 / 2.2)  # an overlap twice as bright in linear light: no blend
    u = white_uniformity_pct(white, r, gamma_c=2.2)
    assert u["pct"] == pytest.approx(100.0, rel=1e-6) and len(u["sides"]) == 2
    white[:, :45] = np.linspace(0.2, 0.7 * 2 ** (1 / 2.2), 45)[None, :, None]  # a slow rise towards the overlap
    white[:, 55:] = 0.7 * 2 ** (1 / 2.2)
    assert white_uniformity_pct(white, r)["pct"] > 20
    assert white_uniformity_pct(white, r, adjacent_px=3)["pct"] < 5  # next to the overlap: even
    mask = np.zeros((H, W), bool)
    mask[:, :30] = True  # no overlap on the mask: no figure
    assert math.isnan(white_uniformity_pct(white, r, mask)["pct"])


def test_psnr_on_a_mask():
    a = np.zeros((4, 4, 3))
    b = a.copy()
    b[0, 0] = 0.1
    m = np.zeros((4, 4), bool)
    m[0, :2] = True
    assert psnr_on(a, b, m) == pytest.approx(10 * math.log10(1 / (0.01 / 2)))
    assert psnr_on(a, b, ~m) == math.inf and math.isnan(psnr_on(a, b, np.zeros((4, 4), bool)))


def test_share_frames_light_each_projectors_share_in_its_colour():
    from lapig.tools.fakes import fake_rig
    from lapig.lapig_core.multi.blend import blend_weights, share_frames

    rig = fake_rig.side_by_side_rig((96, 72), (128, 96))
    maps = [rig.camera_map(k) for k in range(rig.count)]
    weights = blend_weights(maps)
    frames = share_frames(maps, weights, (2.2, 2.0))
    assert [f.shape for f in frames] == [(96, 128, 3), (96, 128, 3)]
    assert frames[0][..., 1:].max() == 0 and frames[1][..., [0, 2]].max() == 0  # red only, green only
    assert frames[0][..., 0].max() == pytest.approx(1.0) and frames[0][..., 0].min() < 0.5  # handing over
    light = [np.power(f, g) for f, g in zip(frames, (2.2, 2.0))]
    # in camera space the two shares' light sums to one colour's worth wherever both reach
    both = maps[0].valid & maps[1].valid
    total = sum(m.sample(li)[..., c] for m, li, c in zip(maps, light, (0, 1)))
    assert np.median(np.abs(total[both] - 1)) < 0.05
