# SPDX-License-Identifier: GPL-3.0-or-later
"""The classical radiometric model of K projectors on one object, in camera space.

Each projector's pixels reach the camera through its own registration, so the only space the K of
them share is the camera's. Per camera pixel x:

    C(x) = f_c( sum_k M_k(x) . f_p,k(P_k)(u_k(x)) + o(x) )

u_k(x): the projector-k pixel camera pixel x sees (its CameraMap); f_p,k(P) = P ** gamma_p,k, sampled
bilinearly in linear light (light adds up within a camera pixel); M_k: a 3x3 colour mixing per projector
(0 where it does not reach); o: ambient light plus every projector's black, which all show together.
Fitted from captures of each projector alone (the others black) and of all black: the gammas by
ClassicalModel's grid search per projector, then M_1..M_K and the shared o by one least squares per pixel
over all those captures (the black ones tie o down for every projector at once).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..common.atomic import atomic_write_npz
from ..common.small_spd import spd_solve
from ..photometric.classical import (ClassicalModel, _as_float_images, _design, _normal_matrix, _to_unit,
                                     search_gammas)
from .camera_map import CameraMap, maps_from_arrays, maps_to_arrays

_SEARCH_PIXELS = 2000
_CHUNK = 16384  # camera pixels per block of the least squares: bounds memory at (chunk, N_k, 4) float64


@dataclass(eq=False)
class JointModel:
    """M: (K,H,W,3,3) float32, rows = camera channels; o: (H,W,3) float32, linear capture units;
    gamma_p: one gamma per projector; maps: one CameraMap per projector."""

    gamma_c: float
    gamma_p: tuple[float, ...]
    M: np.ndarray
    o: np.ndarray
    maps: tuple[CameraMap, ...]
    residual: float = float("nan")  # RMS of the fitted captures' prediction error, encoded units
    together_rms: float = float("nan")  # the same for the all-together check captures, if given
    fit_seconds: float = 0.0
    blend_gamma: tuple[float, ...] | None = None  # the alpha maps' encoding, fitted by the blend probe

    def __post_init__(self):
        self.M = np.asarray(self.M, np.float32)
        self.o = np.asarray(self.o, np.float32)
        self.maps = tuple(self.maps)
        self.gamma_p = tuple(float(g) for g in self.gamma_p)
        k = len(self.maps)
        if self.M.shape[:1] != (k,) or self.M.ndim != 5 or self.M.shape[-2:] != (3, 3):
            raise ValueError(f"M must be (K,H,W,3,3) with K={k} maps, got {self.M.shape}")
        if self.o.shape != self.M.shape[1:3] + (3,) or len(self.gamma_p) != k:
            raise ValueError(f"o must be {self.M.shape[1:3] + (3,)} and one gamma per projector, got "
                             f"{self.o.shape} and {len(self.gamma_p)}")
        if any(m.camera_shape != self.shape for m in self.maps):
            raise ValueError("every CameraMap must have the model's camera shape")
        if self.blend_gamma is not None:
            self.blend_gamma = tuple(float(g) for g in self.blend_gamma)
            if len(self.blend_gamma) != k:
                raise ValueError(f"one blend gamma per projector: {k}, got {len(self.blend_gamma)}")

    @property
    def alpha_gammas(self) -> tuple[float, ...]:
        """The gamma each projector's alpha map is encoded with (blend.encode_alpha): the blend probe's where
        the capture had one (blend_probe.py), else the fitted gamma_p."""
        return self.blend_gamma if self.blend_gamma is not None else self.gamma_p

    @property
    def count(self) -> int:
        return len(self.maps)

    @property
    def shape(self) -> tuple[int, int]:
        return self.M.shape[1:3]

    @property
    def reached(self) -> np.ndarray:
        """(K,H,W) bool: where each projector reaches."""
        return np.stack([m.valid for m in self.maps])

    # ---------------------------------------------------------------- prediction
    def linear_light(self, frames: Sequence[np.ndarray | None]) -> np.ndarray:
        """One projector image per projector ((h,w,3) encoded in [0,1] or uint8; None: black) -> (K,H,W,3)
        float32 linear drives f_p,k(P_k) seen at each camera pixel."""
        if len(frames) != self.count:
            raise ValueError(f"one frame per projector: {self.count}, got {len(frames)}")
        out = np.zeros((self.count,) + self.shape + (3,), np.float32)
        for k, frame in enumerate(frames):
            if frame is not None:
                linear = np.power(_as_float_images(frame, f"frames[{k}]"), np.float32(self.gamma_p[k]))
                out[k] = self.maps[k].sample(linear)
        return out

    def predict_linear(self, q: np.ndarray) -> np.ndarray:
        """(K,H,W,3) per-camera-pixel linear drives -> (H,W,3) float32 predicted capture in [0,1]."""
        lin = np.einsum("khwij,khwj->hwi", self.M, np.asarray(q, np.float32)) + self.o
        return np.power(np.clip(lin, 0.0, 1.0), np.float32(1.0 / self.gamma_c)).astype(np.float32)

    def predict(self, frames: Sequence[np.ndarray | None]) -> np.ndarray:
        """One projector image per projector -> (H,W,3) float32 predicted capture in [0,1]."""
        return self.predict_linear(self.linear_light(frames))

    def single(self, k: int) -> ClassicalModel:
        """Projector k alone as a ClassicalModel registered in camera space (the others showing black)."""
        return ClassicalModel(self.gamma_c, self.gamma_p[k], self.M[k], self.o)

    @classmethod
    def from_classical(cls, model: ClassicalModel, camera_map: CameraMap | None = None) -> "JointModel":
        """A one-projector joint model of a ClassicalModel; without a map, its registered space is the camera's
        (the identity map)."""
        h, w = model.shape
        if camera_map is None:
            yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
            camera_map = CameraMap(xx, yy, np.ones((h, w), bool), (w, h))
        return cls(model.gamma_c, (model.gamma_p,), model.M[None], model.o, (camera_map,))

    # ------------------------------------------------------------------ fitting
    @classmethod
    def fit(cls, maps: Sequence[CameraMap], frames: Sequence[np.ndarray], captures: Sequence[np.ndarray],
            black: np.ndarray, *, together=None, gammas=None, saturation: float | None = 0.998,
            search_pixels: int = _SEARCH_PIXELS, seed: int = 0) -> "JointModel":
        """maps: one CameraMap per projector; frames[k]: (N_k,h_k,w_k,3) the images projector k showed
        alone, captures[k]: (N_k,H,W,3) their captures; black: (H,W,3) or (B,H,W,3) captures of every
        projector showing black. together: optional (frames, capture), one frame per projector shown at
        once, to check that the light adds up (together_rms). gammas: (gamma_c, [gamma_p per projector])
        or None to search them. Captures with a channel at or above `saturation` are left out."""
        t0 = time.perf_counter()
        maps = tuple(maps)
        if not (len(maps) == len(frames) == len(captures)) or not maps:
            raise ValueError(f"one map, frame set and capture set per projector: got {len(maps)}, "
                             f"{len(frames)}, {len(captures)}")
        shape = maps[0].camera_shape
        captures = [_captures(c, shape, f"captures[{k}]") for k, c in enumerate(captures)]
        black = _captures(black, shape, "black")
        if len({c.dtype for c in captures + [black]}) > 1:  # one scale for all: 8-bit and float mixed
            captures, black = [_as_float_images(c, "captures") for c in captures], _as_float_images(black, "black")
        frames = [np.asarray(f) for f in frames]
        for k, (f, c) in enumerate(zip(frames, captures)):
            if f.ndim != 4 or len(f) != len(c):
                raise ValueError(f"frames[{k}] must be (N,h,w,3) with one frame per capture, got {f.shape}")
        if gammas is None:
            gamma_c, gamma_p = _search(maps, frames, captures, black, saturation, search_pixels, seed)
        else:
            gamma_c, gamma_p = float(gammas[0]), tuple(float(g) for g in gammas[1])
        drives = [np.stack([m.sample(np.power(_as_float_images(p, "frame"), np.float32(gp))) for p in f])
                  for m, f, gp in zip(maps, frames, gamma_p)]
        m, o = _least_squares(drives, captures, black, gamma_c, saturation, [mp.valid for mp in maps])
        model = cls(gamma_c, gamma_p, m, o, maps)
        model.residual = model._fit_rms(drives, captures, black)
        if together is not None:
            model.together_rms = model.check(*together)
        model.fit_seconds = time.perf_counter() - t0
        return model

    def _fit_rms(self, drives, captures, black) -> float:
        """RMS prediction error of the fitted captures: each projector's where it reaches, black everywhere."""
        encode = np.float32(1.0 / self.gamma_c)
        errors = [np.power(np.clip(self.o, 0, 1), encode) - _to_unit(b) for b in black]
        for k, (d, c) in enumerate(zip(drives, captures)):
            valid = self.maps[k].valid
            for q, cap in zip(d, c):
                lin = np.einsum("pij,pj->pi", self.M[k][valid], q[valid]) + self.o[valid]
                errors.append(np.power(np.clip(lin, 0, 1), encode) - _to_unit(cap[valid]))
        return _rms(errors)

    def check(self, frames: Sequence[np.ndarray | None], capture: np.ndarray) -> float:
        """RMS (encoded units) of the prediction of a capture of several projectors at once, over the pixels
        some projector reaches: does the light of separately fitted projectors add up?"""
        err = self.predict(frames) - _to_unit(_captures(capture, self.shape, "capture")[0])
        return _rms([err[self.reached.any(axis=0)]])

    # ------------------------------------------------------------------ storage
    def save(self, path) -> None:
        """An .npz at exactly `path`, whole or not at all."""
        atomic_write_npz(path, dict(gamma_c=np.float64(self.gamma_c), gamma_p=np.array(self.gamma_p), M=self.M,
                                    o=self.o, **maps_to_arrays(self.maps), residual=np.float64(self.residual),
                                    together_rms=np.float64(self.together_rms),
                                    blend_gamma=np.array(self.blend_gamma or (), np.float64),
                                    format_version=np.int64(1)))

    @classmethod
    def load(cls, path) -> "JointModel":
        with np.load(path, allow_pickle=False) as z:
            model = cls(float(z["gamma_c"]), tuple(z["gamma_p"]), z["M"], z["o"], maps_from_arrays(z))
            model.residual, model.together_rms = float(z["residual"]), float(z["together_rms"])
            if "blend_gamma" in z.files and z["blend_gamma"].size == model.count:  # older files lack it
                model.blend_gamma = tuple(float(g) for g in z["blend_gamma"])
        return model


def _captures(a, shape, name) -> np.ndarray:
    """(H,W,3) or (N,H,W,3) -> (N,H,W,3): uint8 kept as it is (a real capture set is large; blocks are
    converted as they are used), floats checked and clipped to [0,1]."""
    a = np.asarray(a)
    if a.ndim == 3:
        a = a[None]
    if a.ndim != 4 or a.shape[1:] != tuple(shape) + (3,):
        raise ValueError(f"{name} must be (N,{shape[0]},{shape[1]},3) or ({shape[0]},{shape[1]},3), got {a.shape}")
    return a if a.dtype == np.uint8 else _as_float_images(a, name)


def _rms(errors) -> float:
    sq = sum(float(np.dot(e.ravel(), e.ravel())) for e in errors)
    n = sum(e.size for e in errors)
    return float(np.sqrt(sq / n)) if n else float("nan")


def _search(maps, frames, captures, black, saturation, search_pixels, seed) -> tuple[float, tuple[float, ...]]:
    """Each projector's (gamma_c, gamma_p) by ClassicalModel's grid search on a sample of the camera pixels
    it lights (its captures alone and the black ones, the frames sampled encoded at those pixels); the
    camera is one, so gamma_c is the median of the K estimates."""
    rng = np.random.default_rng(seed)
    found = []
    for m, f, c in zip(maps, frames, captures):
        cams = np.concatenate([c, black])  # (N+B,H,W,3)
        lit = m.valid & (np.ptp(cams, axis=0).max(axis=-1) > (0.02 * 255 if cams.dtype == np.uint8 else 0.02))
        pool = np.flatnonzero(lit if lit.sum() >= 64 else m.valid)
        if pool.size == 0:
            raise ValueError("a projector reaches no camera pixel: its gammas cannot be fitted")
        idx = np.sort(rng.choice(pool, size=min(search_pixels, pool.size), replace=False))
        shown = np.stack([m.sample(_as_float_images(p, "frame")).reshape(-1, 3)[idx] for p in f])
        shown = np.concatenate([shown, np.zeros((len(black),) + shown.shape[1:], np.float32)])
        seen = _to_unit(cams.reshape(len(cams), -1, 3)[:, idx])
        w = None if saturation is None else (~(seen >= saturation).any(-1)).astype(np.float64).T
        gc, gp, _ = search_gammas(shown.transpose(1, 0, 2), seen.transpose(1, 0, 2), w)
        found.append((gc, gp))
    return float(np.median([g[0] for g in found])), tuple(g[1] for g in found)


def _least_squares(drives, captures, black, gamma_c, saturation, valid) -> tuple[np.ndarray, np.ndarray]:
    """Per camera pixel, M_1..M_K and the shared o from every alone and black capture at once.

    Each projector's own captures give ClassicalModel's 4x4 normal equations over [M_k | o] (its design,
    on drives already linear); all share o, and the black captures add to o's equation only. The joint
    system is an arrow (K 3x3 blocks coupled through o): o comes from its Schur complement, then each M_k
    from its 3x3 block, instead of one (3K+1)-square solve per pixel.
    """
    k_count = len(drives)
    h, w = captures[0].shape[1:3]
    hw = h * w
    m = np.zeros((k_count, hw, 3, 3), np.float32)
    o = np.zeros((hw, 3), np.float32)
    for s in range(0, hw, _CHUNK):
        idx = slice(s, min(s + _CHUNK, hw))
        yb, wb = _linear_block(black, idx, gamma_c, saturation)
        count = wb.sum(axis=1)  # o's own equation: sum w o + sum_k b_k . M_k = sum w y
        target = (wb[..., None] * yb).sum(axis=1)
        parts = []
        for k in range(k_count):
            y, wt = _linear_block(captures[k], idx, gamma_c, saturation)
            # a projector's captures say nothing the model can use where it does not reach (its frame's
            # blurred edge still lights a little there, which o, shared by all, would absorb)
            wt *= valid[k].reshape(-1)[idx, None]
            d = drives[k].reshape(len(drives[k]), hw, 3)[:, idx].transpose(1, 0, 2).astype(np.float64)
            g, xt = _normal_matrix(_design(d, 1.0), wt)
            rhs = xt @ y  # (P,4,3)
            coupling = g[:, :3, 3:]  # (P,3,1): how o enters projector k's equations
            inv = spd_solve(g[:, :3, :3], np.concatenate([rhs[:, :3], coupling], axis=2))  # G^-1 [r | b]
            count += g[:, 3, 3] - (coupling[..., 0] * inv[:, :, 3]).sum(axis=1)
            target += rhs[:, 3] - np.einsum("pi,pic->pc", coupling[..., 0], inv[:, :, :3])
            parts.append(inv)
        with np.errstate(divide="ignore", invalid="ignore"):
            offset = target / count[:, None]
        bad = ~np.isfinite(offset).all(axis=1) | (count <= 0)
        offset[bad] = yb[bad].mean(axis=1)  # a broken solve: no projector, the black captures' mean
        o[idx] = offset
        for k, inv in enumerate(parts):
            beta = inv[:, :, :3] - inv[:, :, 3:] * offset[:, None, :]  # (P, projector ch, camera ch)
            beta[bad | ~np.isfinite(beta).all(axis=(1, 2))] = 0.0
            m[k, idx] = np.swapaxes(beta, 1, 2)  # rows: camera channels
    m = m.reshape(k_count, h, w, 3, 3)
    for k, reached in enumerate(valid):  # where a projector's light never arrives its block was empty
        m[k][~reached] = 0.0
    return m, o.reshape(h, w, 3)


def _linear_block(captures, idx, gamma_c, saturation) -> tuple[np.ndarray, np.ndarray]:
    """Pixels idx of (N,H,W,3) captures -> linearised (P,N,3) float64 and sample weights (P,N): 0 for a
    capture with a channel at or above `saturation` (it only says "at least that bright")."""
    c = _to_unit(captures.reshape(len(captures), -1, 3)[:, idx].transpose(1, 0, 2))
    wt = np.ones(c.shape[:2]) if saturation is None else (~(c >= saturation).any(-1)).astype(np.float64)
    return np.power(c, gamma_c), wt
