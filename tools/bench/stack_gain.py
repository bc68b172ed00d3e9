# SPDX-License-Identifier: GPL-3.0-or-later
"""What a stack of projectors gains with PSA on their joint reach (issue 36's stack_psa_gain_db): the same prompt
on the same object lit by several projectors together and by fewer, each adapted to its own joint reach,
compensated jointly and simulated through its own joint model. A measurement (the bench and the research
figures take it), kept out of joint_psa, which stylize itself uses."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ...lapig_core.common.psnr import masked_psnr
from ...lapig_core.multi.joint_model import JointModel
from ...lapig_core.multi.joint_psa import simulated_psnr
from ...lapig_core.multi.stylize import stylize_joint


@dataclass
class StackFigures:
    """PSA's simulated PSNR (dB, on the object) with the stacked projectors and with one, with PSA and without."""

    stacked_psa_psnr: float  # the joint model's capture of the PSA look's images against the PSA look
    stacked_nopsa_psnr: float  # the same without PSA (against the un-adapted look)
    single_psa_psnr: float
    single_nopsa_psnr: float
    # the PSA look's simulated capture against the un-adapted look I0 (what the prompt asked for): how much of
    # the look each rig shows after PSA
    stacked_psa_look_psnr: float = float("nan")
    single_psa_look_psnr: float = float("nan")

    @property
    def stack_psa_gain_db(self) -> float:
        """PSA's PSNR with all the stacked projectors minus with one."""
        return self.stacked_psa_psnr - self.single_psa_psnr

    @property
    def psa_gain_db_stacked(self) -> float:
        return self.stacked_psa_psnr - self.stacked_nopsa_psnr

    @property
    def psa_gain_db_single(self) -> float:
        return self.single_psa_psnr - self.single_nopsa_psnr

    @property
    def stack_look_gain_db(self) -> float:
        """After PSA, the asked look (I0) shown with all the stacked projectors minus with one."""
        return self.stacked_psa_look_psnr - self.single_psa_look_psnr

    def to_dict(self) -> dict:
        d = {k: round(v, 3) for k, v in asdict(self).items()}
        d.update(stack_psa_gain_db=round(self.stack_psa_gain_db, 3),
                 stack_look_gain_db=round(self.stack_look_gain_db, 3),
                 psa_gain_db_stacked=round(self.psa_gain_db_stacked, 3),
                 psa_gain_db_single=round(self.psa_gain_db_single, 3))
        return d


def stack_psa_gain(stacked: JointModel, single: JointModel, surface: np.ndarray, prompt: str,
                   backend: str = "styletransfer", object_mask: np.ndarray | None = None, seed: int = 0,
                   working_size: int = 256, settings=None, single_surface: np.ndarray | None = None,
                   looks: dict | None = None) -> StackFigures:
    """The same prompt on the same object lit by `stacked`'s projectors together and by `single`'s (one of
    them, or fewer): PSA on each one's joint reach, compensated jointly, simulated through each one's model.

    surface: (H,W,3) the capture LGST styles (the all-white-together capture of the stacked rig);
    single_surface: the fewer projectors' white capture (off their reach the target keeps it; None: surface).
    Both models share the camera (one shape). object_mask: the pixels counted (None: where `single` reaches,
    so both count the same pixels). looks: a dict that receives the four JointLooks (for a sheet)."""
    if stacked.shape != single.shape:
        raise ValueError(f"the two models must share the camera: {stacked.shape} and {single.shape}")
    mask = single.reached.any(axis=0) & stacked.reached.any(axis=0)
    if object_mask is not None:
        mask &= np.asarray(object_mask, bool)
    out = {}
    for name, model, surf in (("stacked", stacked, surface),
                              ("single", single, surface if single_surface is None else single_surface)):
        look = stylize_joint(model, surf, prompt, backend, seed, working_size=working_size, object_mask=mask,
                             psa=True, psa_settings=settings, lgst_surface=surface)
        shown = model.predict(look.frames)
        out[name] = (simulated_psnr(model, look, mask), simulated_psnr(model, look.without, mask),
                     float(masked_psnr(shown, look.without.target, mask)))
        if looks is not None:
            looks[name] = look
    return StackFigures(out["stacked"][0], out["stacked"][1], out["single"][0], out["single"][1], out["stacked"][2],
                        out["single"][2])
