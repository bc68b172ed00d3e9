# SPDX-License-Identifier: GPL-3.0-or-later
"""The first look of several projectors: the joint classical model fitted right after the capture.

As one projector's first look (photometric/first_look), it takes seconds and makes Generate work at once.
It is saved in the capture's models folder (JointModel.save) with what the capture's line says: how much
of the object the projectors reach alone and together, and what overlapping costs the black level.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass

import numpy as np

from ..common.atomic import atomic_write_bytes
from .black_level import BlackUplift, model_black_uplift
from .blend import blend_weights
from .blend_probe import BlendGammaFit, fit_blend_gammas
from .capture_set import FIRST_LOOK, MODELS, MultiCaptureSet, joint_model_path
from .coverage import Coverage, coverage
from .additivity import additive_gamma
from .joint_model import JointModel, _search  # the per-projector gamma search

DEFAULT_CONTRAST = 2000.0  # a projector's contrast ratio where the capture does not record its black level


@dataclass
class JointFirstLook:
    model: JointModel
    coverage: Coverage
    uplift: BlackUplift
    names: tuple
    seconds: float
    blend_fit: BlendGammaFit | None = None

    @property
    def coverage_single(self) -> float:
        """The share of the object the best projector alone reaches."""
        return max(self.coverage.per_projector)

    @property
    def coverage_joint(self) -> float:
        return self.coverage.reached

    def status_line(self) -> str:
        """The Models step's and the capture's line."""
        return (f"First look (joint classical model of {self.model.count} projectors): together they reach "
                f"{self.coverage_joint:.0%} of the object, the best one alone {self.coverage_single:.0%}. "
                f"{self.uplift.sentence()}")

    def to_dict(self) -> dict:
        return {"projectors": list(self.names), "coverage_single": self.coverage_single,
                "coverage_joint": self.coverage_joint, "per_projector": list(self.coverage.per_projector),
                "overlap": self.coverage.overlap, "black_uplift": _finite(self.uplift.uplift),
                "black_uplift_sentence": self.uplift.sentence(), "fit_residual": _finite(self.model.residual),
                "together_rms": _finite(self.model.together_rms), "seconds": round(self.seconds, 3),
                "blend_gamma": self.blend_fit.to_dict() if self.blend_fit is not None else None,
                "line": self.status_line()}


def _finite(value: float):
    return float(value) if np.isfinite(value) else None


def contrasts_of(meta: dict, count: int) -> list[float]:
    """Each projector's contrast ratio from the black level its capture records (1 / black level)."""
    recorded = meta.get("projectors") or []
    out = []
    for k in range(count):
        black = (recorded[k] if k < len(recorded) else {}).get("black_level") or 0.0
        out.append(1.0 / black if black > 1e-6 else DEFAULT_CONTRAST)
    return out


def joint_gammas(cs: MultiCaptureSet):
    """(gamma_c, [gamma_p per projector]): the camera's from the overlap's additivity, each projector's
    searched ratio to it kept; None (JointModel's own search) where the projectors do not overlap."""
    whites = [c[0] for c in cs.captures]  # each projector's first frame alone is full white (capture.training_frames)
    gamma_c = additive_gamma(cs.together, whites, cs.black, np.stack([m.valid for m in cs.maps]))
    if gamma_c is None:
        return None
    searched_c, searched_p = _search(cs.maps, cs.frames, cs.captures, cs.black[None], 0.998, 2000, 0)
    return gamma_c, [gp * gamma_c / searched_c for gp in searched_p]


def probe_fit(cs: MultiCaptureSet, model: JointModel) -> BlendGammaFit | None:
    """The alpha maps' gammas from the capture's blend probe (None: a set without one, no overlap to read)."""
    if cs.probe is None or cs.probe_frames is None or not cs.captures:
        return None
    whites = [c[0] for c in cs.captures]  # each projector's first frame alone is full white
    return fit_blend_gammas(cs.maps, model.gamma_p, model.gamma_c, cs.probe_frames, cs.probe, whites, cs.black,
                            cs.object_mask)


def fit_joint_first_look(cs: MultiCaptureSet) -> JointFirstLook:
    """Fit the joint model on the capture's alone and black captures (checked on the all-together one),
    save it and its summary in the capture's models folder."""
    t0 = time.perf_counter()
    model = JointModel.fit(cs.maps, cs.frames, cs.captures, cs.black, together=(cs.together_frames(), cs.together),
                           gammas=joint_gammas(cs))
    blend_fit = probe_fit(cs, model)
    if blend_fit is not None:
        model.blend_gamma = blend_fit.gammas
    cover = coverage(cs.maps, cs.object_mask)
    uplift = model_black_uplift(model, contrasts_of(cs.meta, cs.count), blend_weights(cs.maps))
    look = JointFirstLook(model, cover, uplift, cs.names, time.perf_counter() - t0, blend_fit)
    model.save(joint_model_path(cs.setup_dir))
    record = {**look.to_dict(), "fingerprint": cs.meta.get("fingerprint")}
    atomic_write_bytes(cs.setup_dir / MODELS / FIRST_LOOK, json.dumps(record, indent=2).encode("utf-8"))
    return look


def load_joint_model(setup_dir) -> JointModel | None:
    """The capture's saved joint model, or None where its first look was not fitted (or is damaged)."""
    path = joint_model_path(setup_dir)
    if not path.is_file():
        return None
    try:
        return JointModel.load(path)
    except (OSError, ValueError, KeyError):
        return None
