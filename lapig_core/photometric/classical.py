# SPDX-License-Identifier: GPL-3.0-or-later
"""Classical per-pixel baseline for projector compensation and simulation (numpy only).

The standard radiometric model of a projector-camera system, every pixel registered into
projector space::

    C = f_c( M(y,x) . f_p(P) + o(y,x) )

f_p(P) = P ** gamma_p is the projector's transfer, f_c(L) = L ** (1 / gamma_c) the camera
response, M a 3x3 colour-mixing matrix per pixel (surface albedo times the spectral overlap of
projector and camera channels) and o a per-pixel offset (ambient light plus black level).

It is the reference the learned models (PCNet for simulation, CompenNeSt for compensation) have
to beat, and a fallback that needs no torch and fits in seconds: linearise the captures with the
fitted camera response, then fit M and o by least squares, all pixels at once.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..common.atomic import atomic_write_npz
from ..common.small_spd import spd_inverse, spd_solve

GAMMA_RANGE = (1.0, 3.0)
# (step, half width around the previous best); None = the whole range
_SEARCH_LEVELS = ((0.25, None), (0.05, 0.2), (0.01, 0.04))
_SEARCH_PIXELS = 2000
_SEARCH_SAMPLES = 100_000  # pixels x images for the search; fewer pixels when N is large
_RIDGE = 1e-6  # relative to the trace of each pixel's normal matrix
_CHUNK = 8192  # pixels per block of the full fit: bounds memory at (chunk, N, 4) float64
# Singular values of M below this (linear capture per unit of linear projector light) mean the
# projector cannot change what the camera sees there: such directions get no compensation.
_DEAD_SIGMA = 1e-3


def _as_float_images(a: np.ndarray, name: str) -> np.ndarray:
    """uint8 or float input -> float32 in [0,1]; anything with a last axis other than 3 is refused."""
    a = np.asarray(a)
    if a.ndim < 3 or a.shape[-1] != 3:
        raise ValueError(f"{name} must be RGB images shaped (N,H,W,3) or (H,W,3), got {a.shape}")
    if a.dtype == np.uint8:
        return a.astype(np.float32) / np.float32(255.0)
    a = a.astype(np.float32, copy=False)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf")
    return np.clip(a, 0.0, 1.0)


def _images(a, name: str) -> np.ndarray:
    """Shape check only; conversion to float happens per block so big sets are not copied whole."""
    a = np.asarray(a)
    if a.ndim < 3 or a.shape[-1] != 3:
        raise ValueError(f"{name} must be RGB images shaped (N,H,W,3) or (H,W,3), got {a.shape}")
    if a.dtype != np.uint8 and not np.issubdtype(a.dtype, np.floating):
        raise ValueError(f"{name} must be uint8 or float images, got {a.dtype}")
    return a


def _to_unit(a: np.ndarray) -> np.ndarray:
    """A block of images -> float64 in [0,1]; NaN/inf are refused rather than fitted."""
    if a.dtype == np.uint8:
        return a.astype(np.float64) * (1.0 / 255.0)
    a = a.astype(np.float64)
    if not np.isfinite(a).all():
        raise ValueError("images contain NaN or inf")
    return np.clip(a, 0.0, 1.0, out=a)


def _samples(p_all, c_all, idx, saturation):
    """Pixels idx of (N, HW, 3) sets -> per-pixel (P, N, 3) float64 blocks and sample weights.

    Weight 0 marks captures with a channel at or above `saturation`: a clipped capture only says
    "at least 1", so fitting it as 1 would bend the whole pixel's fit.
    """
    p = _to_unit(np.ascontiguousarray(p_all[:, idx].transpose(1, 0, 2)))
    c = _to_unit(np.ascontiguousarray(c_all[:, idx].transpose(1, 0, 2)))
    w = None
    if saturation is not None:
        sat = (c >= saturation).any(axis=-1)
        if sat.any():
            w = (~sat).astype(np.float64)
    return p, c, w


def _design(p: np.ndarray, gamma_p: float) -> np.ndarray:
    """(..., N, 3) projector values -> (..., N, 4) design [p ** gamma_p, 1]."""
    x = np.empty(p.shape[:-1] + (4,), dtype=p.dtype)
    np.power(p, gamma_p, out=x[..., :3])
    x[..., 3] = 1.0
    return x


def _normal_matrix(x: np.ndarray, w: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel (X^T W X + ridge, X^T W): the ridge makes rank-deficient designs give the min-norm answer."""
    xt = np.swapaxes(x if w is None else x * w[..., None], -1, -2)
    g = xt @ x
    tr = np.trace(g, axis1=-2, axis2=-1)
    ridge = _RIDGE * tr + 1e-12
    g[..., range(4), range(4)] += ridge[..., None]
    return g, xt


class _SearchProblem:
    """Fits of a pixel sample for many (gamma_c, gamma_p) pairs, caching work shared across pairs.

    The normal matrix depends on gamma_p only and the linearised targets on gamma_c only, so a
    grid costs one inverse per gamma_p and one power per gamma_c.
    """

    def __init__(self, p: np.ndarray, c: np.ndarray, w: np.ndarray | None):
        self.p, self.c, self.w = p, c, w
        self.c32 = c.astype(np.float32)
        self._by_gp: dict = {}
        self._by_gc: dict = {}
        self.scores: dict = {}

    def _gp(self, gp: float):
        key = round(gp, 6)
        if key not in self._by_gp:
            x = _design(self.p, gp)
            g, xt = _normal_matrix(x, self.w)
            self._by_gp[key] = (x, xt, spd_inverse(g), x.astype(np.float32))
        return self._by_gp[key]

    def _gc(self, gc: float):
        key = round(gc, 6)
        if key not in self._by_gc:
            self._by_gc[key] = np.power(self.c, gc)
        return self._by_gc[key]

    def score(self, gc: float, gp: float) -> float:
        """Mean squared error of the fitted model, in encoded capture units (comparable across gamma_c)."""
        key = (round(gc, 6), round(gp, 6))
        if key not in self.scores:
            x, xt, ginv, x32 = self._gp(gp)
            b = ginv @ (xt @ self._gc(gc))  # float64 solve
            # Predictions in float32: numpy's batched float32 matmul is ~10x faster here, and
            # 1e-7 relative error is far below the score differences the grid has to resolve.
            pred = x32 @ b.astype(np.float32)
            np.maximum(pred, 0.0, out=pred)
            np.minimum(pred, 1.0, out=pred)
            np.power(pred, np.float32(1.0 / gc), out=pred)
            pred -= self.c32
            flat = pred.ravel()
            mse = float(np.dot(flat, flat)) / flat.size
            self.scores[key] = mse if np.isfinite(mse) else np.inf
        return self.scores[key]


def _grid(center: float | None, step: float, half: float | None, lo: float, hi: float) -> np.ndarray:
    if half is None:
        g = np.arange(lo, hi + step / 2, step)
    else:
        g = center + np.arange(-half, half + step / 2, step)
    return np.unique(np.round(np.clip(g, lo, hi), 6))


def search_gammas(p: np.ndarray, c: np.ndarray, w: np.ndarray | None = None,
                  gamma_range=GAMMA_RANGE, levels=_SEARCH_LEVELS) -> tuple[float, float, float]:
    """Coarse-to-fine grid search of (gamma_c, gamma_p) on a pixel sample.

    p, c: (S, N, 3) projector inputs and captures in [0,1]; w: optional (S, N) sample weights.
    Returns (gamma_c, gamma_p, mse). A grid, not a gradient method: the score is cheap, bumpy
    in places (clipping) and two-dimensional, and a grid cannot diverge.
    """
    prob = _SearchProblem(np.asarray(p, np.float64), np.asarray(c, np.float64), w)
    lo, hi = gamma_range
    best = (None, None)
    for step, half in levels:
        gcs = _grid(best[0], step, half, lo, hi)
        gps = _grid(best[1], step, half, lo, hi)
        scores = {(gc, gp): prob.score(gc, gp) for gp in gps for gc in gcs}
        best = min(scores, key=scores.get)
    return float(best[0]), float(best[1]), prob.score(*best)


@dataclass(eq=False)
class ClassicalModel:
    """Per-pixel radiometric model C = (M f_p(P) + o) ** (1/gamma_c), f_p(P) = P ** gamma_p.

    M: (H,W,3,3) float32, rows = camera channels, columns = projector channels; o: (H,W,3)
    float32, both in linear capture units.
    """

    gamma_c: float
    gamma_p: float
    M: np.ndarray
    o: np.ndarray
    residual: float = float("nan")  # RMS of simulate(train) - train captures, encoded units
    fit_seconds: float = 0.0
    _pinv: tuple | None = field(default=None, init=False, repr=False)  # (M it was made from, pinv)

    def __post_init__(self):
        self.M = np.asarray(self.M, dtype=np.float32)
        self.o = np.asarray(self.o, dtype=np.float32)
        if self.M.ndim != 4 or self.M.shape[-2:] != (3, 3):
            raise ValueError(f"M must be shaped (H,W,3,3), got {self.M.shape}")
        if self.o.shape != self.M.shape[:2] + (3,):
            raise ValueError(f"o must be shaped {self.M.shape[:2] + (3,)}, got {self.o.shape}")
        if not (self.gamma_c > 0 and self.gamma_p > 0):
            raise ValueError(f"gammas must be positive, got {self.gamma_c}, {self.gamma_p}")

    @property
    def shape(self) -> tuple[int, int]:
        return self.M.shape[:2]

    # ------------------------------------------------------------------ fitting
    @classmethod
    def fit(cls, prj: np.ndarray, cam: np.ndarray, gammas=None, *, saturation: float | None = 0.998,
            gamma_range=GAMMA_RANGE, search_pixels: int = _SEARCH_PIXELS,
            seed: int = 0) -> "ClassicalModel":
        """Fit gammas (unless given as (gamma_c, gamma_p)), then M and o for every pixel.

        prj, cam: (N,H,W,3) projector images and their registered captures, N >= 4 (four
        unknowns per channel and pixel). Samples with a capture channel at or above `saturation`
        are left out of the least squares, because a clipped capture only says "at least 1";
        None keeps them all. The gamma search runs on at most `search_pixels` random lit
        pixels (fewer when N is large), over `gamma_range` for both gammas.
        """
        t0 = time.perf_counter()
        prj, cam = _images(prj, "prj"), _images(cam, "cam")
        if prj.ndim != 4 or prj.shape != cam.shape:
            raise ValueError(f"prj and cam must both be (N,H,W,3) with equal shapes, got "
                             f"{prj.shape} and {cam.shape}")
        n, h, w_, _ = prj.shape
        if n < 4:
            raise ValueError(f"the classical model needs at least 4 projector/capture pairs "
                             f"(3x3 matrix + offset per pixel), got {n}")
        hw = h * w_
        p_all, c_all = prj.reshape(n, hw, 3), cam.reshape(n, hw, 3)

        if gammas is None:
            gamma_c, gamma_p = cls._search(p_all, c_all, saturation, search_pixels, seed,
                                           gamma_range)
        else:
            gamma_c, gamma_p = (float(g) for g in gammas)
            if not (gamma_c > 0 and gamma_p > 0):
                raise ValueError(f"gammas must be positive, got {gammas}")

        m = np.empty((hw, 3, 3), np.float32)
        o = np.empty((hw, 3), np.float32)
        sq_err = 0.0
        for s in range(0, hw, _CHUNK):
            idx = slice(s, min(s + _CHUNK, hw))
            p, c, wt = _samples(p_all, c_all, idx, saturation)
            x = _design(p, gamma_p)
            y = np.power(c, gamma_c)
            g, xt = _normal_matrix(x, wt)
            b = spd_solve(g, xt @ y)  # (chunk, 4, 3), float64; SPD: the ridge
            # Too few usable samples or a numerically broken solve: predict the mean capture.
            used = np.full(len(b), n) if wt is None else wt.sum(axis=1)
            bad = (used < 4) | ~np.isfinite(b).all(axis=(1, 2))
            if bad.any():
                b[bad] = 0.0
                b[bad, 3, :] = np.power(c[bad].mean(axis=1), gamma_c)
            m[idx] = np.swapaxes(b[:, :3, :], 1, 2)  # rows: camera channels
            o[idx] = b[:, 3, :]
            pred = x.astype(np.float32) @ b.astype(np.float32)
            np.clip(pred, 0.0, 1.0, out=pred)
            np.power(pred, np.float32(1.0 / gamma_c), out=pred)
            err = (pred - c).ravel()
            sq_err += float(np.dot(err, err))
        model = cls(gamma_c, gamma_p, m.reshape(h, w_, 3, 3), o.reshape(h, w_, 3))
        model.residual = float(np.sqrt(sq_err / (n * hw * 3)))
        model.fit_seconds = time.perf_counter() - t0
        return model

    @staticmethod
    def _search(p_all, c_all, saturation, search_pixels, seed, gamma_range) -> tuple[float, float]:
        """Grid-search the gammas on a random sample of pixels where the projector changes the capture.

        Dead pixels (outside the object) fit any gammas equally well and would only dilute the
        score, so candidates whose capture hardly varies are skipped.
        """
        n, hw = p_all.shape[:2]
        rng = np.random.default_rng(seed)
        n_pix = min(search_pixels, max(256, _SEARCH_SAMPLES // n), hw)
        cand = np.sort(rng.choice(hw, size=min(hw, 4 * n_pix), replace=False))
        _, c, _ = _samples(p_all, c_all, cand, None)
        lit = cand[np.ptp(c, axis=1).max(axis=-1) > 0.02]
        pool = lit if lit.size >= min(64, n_pix) else cand
        idx = np.sort(rng.choice(pool, size=min(n_pix, pool.size), replace=False))
        p, c, w = _samples(p_all, c_all, idx, saturation)
        gamma_c, gamma_p, _ = search_gammas(p, c, w, gamma_range=gamma_range)
        return gamma_c, gamma_p

    # --------------------------------------------------------------- prediction
    def _check(self, a: np.ndarray, name: str) -> tuple[np.ndarray, bool]:
        a = _as_float_images(a, name)
        single = a.ndim == 3
        if single:
            a = a[None]
        if a.ndim != 4 or a.shape[1:3] != self.shape:
            raise ValueError(f"{name} must be (N,{self.shape[0]},{self.shape[1]},3) or "
                             f"({self.shape[0]},{self.shape[1]},3), got {a.shape}")
        return a, single

    def simulate(self, prj: np.ndarray) -> np.ndarray:
        """Projector image(s) -> predicted capture(s) in [0,1], float32, same leading shape."""
        p, single = self._check(prj, "prj")
        lin = np.einsum("hwij,nhwj->nhwi", self.M, np.power(p, np.float32(self.gamma_p))) + self.o
        out = np.power(np.clip(lin, 0.0, 1.0), np.float32(1.0 / self.gamma_c)).astype(np.float32)
        return out[0] if single else out

    def pseudo_inverse(self) -> np.ndarray:
        """Per-pixel pseudo-inverse of M, dropping directions the projector cannot drive.

        Truncating small singular values (absolute, _DEAD_SIGMA) makes a dead pixel (M ~ 0, e.g.
        outside the object or I+ ~ I-) compensate to 0 instead of dividing noise by noise.
        """
        if self._pinv is None or self._pinv[0] is not self.M:
            u, s, vt = np.linalg.svd(self.M.astype(np.float64))
            keep = s > max(_DEAD_SIGMA, 1e-6 * float(s.max(initial=0.0)))
            s_inv = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
            pinv = np.swapaxes(vt, -1, -2) @ (s_inv[..., None] * np.swapaxes(u, -1, -2))
            self._pinv = (self.M, pinv.astype(np.float32))
        return self._pinv[1]

    def compensate(self, target: np.ndarray) -> np.ndarray:
        """Desired capture(s) -> projector image(s) in [0,1] that should produce them.

        Solves M x = target^gamma_c - o per pixel; unreachable targets are clipped to the
        projector's range [0,1] (a simple projection, not a box-constrained least squares).
        """
        x, single = self._unclipped_inverse(target)
        out = np.power(np.clip(x, 0.0, 1.0), np.float32(1.0 / self.gamma_p)).astype(np.float32)
        return out[0] if single else out

    def _unclipped_inverse(self, target: np.ndarray) -> tuple[np.ndarray, bool]:
        """M^+ (target^gamma_c - o) per pixel, (N,H,W,3) in linear projector units, before the clip to
        the projector's range; and whether a single image was given."""
        t, single = self._check(target, "target")
        rhs = np.power(t, np.float32(self.gamma_c)) - self.o
        return np.einsum("hwij,nhwj->nhwi", self.pseudo_inverse(), rhs), single

    def reachable(self, target: np.ndarray, tolerance: float = 0.01) -> np.ndarray:
        """(N,H,W) bool (or (H,W)): pixels whose target this model reaches without clipping the
        projector to [0,1], every channel within `tolerance`. Elsewhere no compensation can show the
        target, by this model's account, and every method's error there is mostly the surface's limit."""
        x, single = self._unclipped_inverse(target)
        inside = ((x >= -tolerance) & (x <= 1.0 + tolerance)).all(axis=-1)
        return inside[0] if single else inside

    # ------------------------------------------------------------------ storage
    def save(self, path) -> None:
        """Write an .npz at exactly `path`, whole or not at all."""
        atomic_write_npz(path, dict(gamma_c=np.float64(self.gamma_c), gamma_p=np.float64(self.gamma_p),
                                    M=self.M, o=self.o, residual=np.float64(self.residual),
                                    fit_seconds=np.float64(self.fit_seconds), format_version=np.int64(1)))

    @classmethod
    def load(cls, path) -> "ClassicalModel":
        with np.load(path, allow_pickle=False) as z:
            model = cls(float(z["gamma_c"]), float(z["gamma_p"]), z["M"], z["o"])
            model.residual = float(z["residual"]) if "residual" in z else float("nan")
            model.fit_seconds = float(z["fit_seconds"]) if "fit_seconds" in z else 0.0
        return model
