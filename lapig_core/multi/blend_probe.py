# SPDX-License-Identifier: GPL-3.0-or-later
"""The blend checked by the camera: the gamma each projector's alpha map is encoded with.

An alpha map holds fractions of linear light; a media server multiplies the projector's signal by the
map encoded as alpha ** (1 / g). That is right only if g is the projector's own curve. The joint fit's
gamma_p is not that curve: captures fix only the camera and projector curves together, so where the camera
has a toe or a projector leaks black, the fit can split the curves wrongly and still predict every capture well
(on the studio wall it gave 2.44 and 2.31 for projectors that follow 2.2, and the blended white was 5 % too
bright in the overlap).

So the capture shows the blend once: every projector its alpha map, encoded with PROBE_GAMMA, at once
(`probe_frames`). In the overlap the capture P of that, each projector's white alone A_k and the all-black B
satisfy, in linear light,

    P - B = sum_k (A_k - B) * s_k ** (gamma_k)

s_k: the probe frame's value projector k shows at that camera pixel; gamma_k: its true curve. `fit_blend_gammas`
first finds one factor on the fit's gamma_p shared by all (the fit's error is mostly the camera's, which all
projectors share) by bisection on the median relative residual over the overlap's mixed pixels, then each
projector's own gamma from there by a robust Gauss-Newton (the overlap's ramps cross, so the pixels where
one projector gives little light weigh the low end of its curve), kept only where it explains the probe
clearly better than the shared factor (OWN_CURVES_GAIN). The fit is self-referenced: where the projectors' whites are alike, the
right factor makes the blended light equal to the light alone, whatever the camera's curve, so an error in
gamma_c hardly moves it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .blend import alpha_maps, blend_weights, encode_alpha
from .camera_map import CameraMap

PROBE_GAMMA = 2.2  # the alpha maps' encoding while capturing: no gamma is fitted yet
SCALE_RANGE = (0.4, 2.5)  # the shared factor on gamma_p searched
GAMMA_RANGE = (1.0, 4.0)  # a projector's own curve outside this: the shared factor stands
OWN_CURVES_GAIN = 0.85  # each projector's own curve when it leaves at most this share of the shared fit's residual
MIN_PIXELS = 50  # mixed overlap pixels below which the probe says nothing
_MIXED = (0.05, 0.95)  # a pixel counts where no projector's share of the light is outside this range
_CLIPPED = 0.99


def probe_frames(maps: Sequence[CameraMap], weights: np.ndarray | None = None) -> list[np.ndarray]:
    """One uint8 (h_k,w_k,3) frame per projector: its alpha map (blend_weights of the maps unless given)
    encoded with PROBE_GAMMA, grey."""
    weights = blend_weights(maps) if weights is None else weights
    frames = []
    for alpha in alpha_maps(maps, weights):
        encoded = np.round(encode_alpha(alpha, PROBE_GAMMA) * 255).astype(np.uint8)
        frames.append(np.repeat(encoded[..., None], 3, axis=-1))
    return frames


@dataclass(frozen=True)
class BlendGammaFit:
    """gammas: the alpha maps' encoding gamma per projector; scale: their shared factor on gamma_p;
    pixels: the overlap pixels it was fitted on; shared: True where the gammas are gamma_p times `scale` (the
    overlap did not tell the projectors' curves apart), False where each projector's was fitted. probe_error: the median relative error of the blended light
    there against the exact blend of the whites alone, as captured (alphas encoded with PROBE_GAMMA);
    gamma_p_error: the same predicted for alphas encoded with the joint fit's gamma_p (what the blend was
    before the probe)."""

    gammas: tuple[float, ...]
    scale: float
    pixels: int
    shared: bool
    probe_error: float
    gamma_p_error: float

    def to_dict(self) -> dict:
        return {"gammas": [round(g, 4) for g in self.gammas], "scale": round(self.scale, 4), "pixels": self.pixels,
                "shared": self.shared, "probe_error": round(self.probe_error, 4), "gamma_p_error": round(self.gamma_p_error, 4),
                "probe_gamma": PROBE_GAMMA}


def _linear(image, gamma_c: float) -> np.ndarray:
    """(H,W,3) uint8 or float capture -> (H,W) linear light (channel mean)."""
    a = np.asarray(image)
    a = a.astype(np.float64) / 255.0 if a.dtype == np.uint8 else np.asarray(a, np.float64)
    return np.power(np.clip(a, 0.0, 1.0), gamma_c).mean(axis=-1)


def fit_blend_gammas(maps: Sequence[CameraMap], gamma_p: Sequence[float], gamma_c: float,
                     frames: Sequence[np.ndarray], probe, alone_whites: Sequence, black,
                     mask: np.ndarray | None = None) -> BlendGammaFit | None:
    """The alpha maps' gammas from the probe capture, or None where it says nothing (fewer than MIN_PIXELS
    mixed, unclipped overlap pixels, or no factor in SCALE_RANGE explains them).
    frames: the probe frames shown (uint8, probe_frames); probe: their capture; alone_whites[k]: the capture
    of projector k alone at full white; black: every projector black; all (H,W,3)."""
    maps = list(maps)
    if len(maps) < 2 or not (len(maps) == len(gamma_p) == len(frames) == len(alone_whites)):
        return None
    b = _linear(black, gamma_c)
    p = _linear(probe, gamma_c) - b
    d = np.stack([_linear(a, gamma_c) - b for a in alone_whites])  # (K,H,W) each projector's white light
    shown = np.stack([m.sample(np.asarray(f, np.float32).mean(axis=-1) / 255.0) for m, f in zip(maps, frames)])
    reached = np.stack([m.valid for m in maps]) & (d > 0.01)
    share = np.where(reached, d * np.power(shown, PROBE_GAMMA), 0.0)  # the light asked of each, PROBE_GAMMA's
    asked = share.sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        top = np.where(asked > 0, share.max(axis=0) / asked, 1.0)
    pick = ((reached.sum(axis=0) >= 2) & (top > _MIXED[0]) & (top < _MIXED[1]) & (asked > 0.02)
            & (np.asarray(probe).max(axis=-1) < (_CLIPPED * 255 if np.asarray(probe).dtype == np.uint8 else _CLIPPED)))
    if mask is not None:
        pick &= np.asarray(mask, bool)
    if int(pick.sum()) < MIN_PIXELS:
        return None
    d_, s_, p_, r_ = d[:, pick], shown[:, pick], p[pick], reached[:, pick]
    norm = d_.sum(axis=0) / r_.sum(axis=0)  # the light alone, per pixel: relative errors of it
    gp = np.asarray(gamma_p, np.float64)[:, None]

    def residual(exponents) -> np.ndarray:  # (K,1) exponents -> the blended light's relative error per pixel
        return (np.where(r_, d_ * np.power(s_, exponents), 0.0).sum(axis=0) - p_) / norm

    def error(exponents) -> float:
        return float(np.median(residual(exponents)))

    lo, hi = SCALE_RANGE
    if not (error(gp * lo) >= 0 >= error(gp * hi)):  # larger exponents: less light predicted
        return None
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if error(gp * mid) > 0:
            lo = mid
        else:
            hi = mid
    scale = 0.5 * (lo + hi)
    common = gp[:, 0] * scale
    own = _per_projector(common, d_, s_, p_, r_, norm)

    def spread(exponents) -> float:  # the median absolute relative residual
        return float(np.median(np.abs(residual(exponents[:, None]))))

    # each projector's own curve only where it explains the probe clearly better than the shared factor: where
    # the overlap's light is uneven (a bust lit from the sides) the split between projectors is weakly determined
    shared = own is None or spread(own) > OWN_CURVES_GAIN * spread(common)
    gammas = common if shared else own
    alphas = np.power(s_, PROBE_GAMMA)  # the linear shares the probe asked for
    exact = np.where(r_, d_ * alphas, 0.0).sum(axis=0)
    # encoded with gamma_p, each projector's light would follow alpha ** (true gamma / gamma_p)
    with_gamma_p = np.where(r_, d_ * np.power(alphas, gammas[:, None] / gp), 0.0).sum(axis=0)
    return BlendGammaFit(tuple(float(g) for g in gammas), scale, int(pick.sum()), shared,
                         probe_error=float(np.median(p_ / np.maximum(exact, 1e-9))) - 1.0,
                         gamma_p_error=float(np.median(with_gamma_p / np.maximum(exact, 1e-9))) - 1.0)


def _per_projector(start, d, s, p, reached, norm) -> np.ndarray | None:
    """Each projector's own exponent by a robust Gauss-Newton from the shared fit's `start`: the ramps of the
    overlap cross, so a pixel where one projector gives little light weighs its curve's low end. None where
    the overlap does not tell the projectors apart (an ill-conditioned system) or the result leaves
    GAMMA_RANGE: the shared factor stands."""
    g = np.asarray(start, np.float64).copy()
    on = reached & (s > 0)
    logs = np.log(np.where(on, s, 1.0))
    for _ in range(20):
        terms = np.where(on, d * np.power(np.where(on, s, 1.0), g[:, None]), 0.0)  # (K,P)
        r = (terms.sum(axis=0) - p) / norm
        jac = (terms * logs / norm).T  # (P,K)
        mad = 1.4826 * np.median(np.abs(r - np.median(r))) + 1e-9
        w = np.minimum(1.0, 2.0 * mad / np.maximum(np.abs(r), 1e-12))  # Huber: outliers count less
        a = jac.T @ (jac * w[:, None])
        if np.linalg.cond(a) > 1e8:
            return None
        step = np.linalg.solve(a + 1e-9 * np.trace(a) * np.eye(len(g)), -(jac.T @ (w * r)))
        g += np.clip(step, -0.5, 0.5)
        if np.abs(step).max() < 1e-5:
            break
    if not np.isfinite(g).all() or g.min() < GAMMA_RANGE[0] or g.max() > GAMMA_RANGE[1]:
        return None
    return g
