# SPDX-License-Identifier: GPL-3.0-or-later
"""A show on a rig of several projectors (issues 36 and 38): every frame made in camera space, then one frame per
projector.

frames.FrameMaker makes a show's frames for one projector in its own frame. Several projectors share only the
camera's frame, where their look was made (multi/stylize), so a JointShowSetup hands FrameMaker:
- models: the K projectors as one virtual projector at the looks' working frame (multi/joint_psa), so a moving or
  morph frame's tone field adapts to their joint reach as Generate's PSA did, with the same warm start and pulls;
- output_size and references there: the camera's size and the all-white-together capture (the surface LGST styles);
- project(target): the joint box solve (multi/joint_solve) turns the frame's target into each projector's frame at
  its native size; the blend weights are computed once for the whole show;
- gammas: each projector's transfer, in whose linear light a dissolve mixes that projector's frames;
- look_surface: the white-lit surface at the working frame, which the looks' backends are prepared on, as
  multi/stylize prepared them; a look's theta and tone field come from its result's look_state.npz, else PSA runs
  again on the joint reach with the settings result.json records;
- offsets(result): a refined result's correction per projector (refined minus open-loop image), carried onto
  that look's frames, as one projector's show carries its refinement.
Holds, keyed dissolves, morphs and motions are then FrameMaker's own: nothing of the schedule is repeated here.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import torch

from ..capture.native_references import References
from .frames import ShowSetup
from .model import ShowError

DEFAULT_WORKING_SIZE = 256  # the add-on's Working size default (multi/stylize's working_size)


class JointShowSetup(ShowSetup):
    """model: the rig's JointModel; surface: (H,W,3) float32 the all-white-together capture at the camera's size;
    object_mask: (H,W) bool where the camera sees the object (None: where some projector reaches); working_size:
    the long side the looks were made at (result.json's psa.working_size); gammas: each projector's transfer
    (None: 2.2 each); fingerprint: the capture's (a look made on another capture is refused)."""

    def __init__(self, model, surface: np.ndarray, object_mask: np.ndarray | None = None,
                 working_size: int = DEFAULT_WORKING_SIZE, gammas=None, fingerprint: str | None = None):
        from ..multi.blend import blend_weights
        from ..multi.joint_psa import joint_surface_models
        from ..multi.stylize import working_surface

        surface = np.asarray(surface, np.float32)
        if surface.shape[:2] != tuple(model.shape):
            raise ShowError(f"the surface is {surface.shape[1]}x{surface.shape[0]}, the camera "
                            f"{model.shape[1]}x{model.shape[0]}")
        reached = model.reached.any(axis=0)
        on = reached if object_mask is None else reached & np.asarray(object_mask, bool)
        small = working_surface(surface, int(working_size))
        h, w = small.shape[:2]
        on_small = on if (h, w) == on.shape else cv2.resize(on.astype(np.float32), (w, h),
                                                              interpolation=cv2.INTER_AREA) > 0.5
        super().__init__(joint_surface_models(model, (h, w), on_small, small), references=self._camera_references,
                         fingerprint=fingerprint)
        self.model, self.surface, self.on, self.reached = model, surface, on, reached
        self.look_surface = torch.from_numpy(np.ascontiguousarray(small.transpose(2, 0, 1)))[None]
        self.weights = blend_weights(model.maps)
        gammas = [2.2] * model.count if gammas is None else [float(g) for g in gammas]
        if len(gammas) != model.count:
            plural = "" if len(gammas) == 1 else "s"
            raise ShowError(f"{len(gammas)} projector transfer{plural} for a rig of {model.count} projectors")
        self.gammas = tuple(gammas)
        self.output_size = (int(model.shape[1]), int(model.shape[0]))  # (width, height): the camera's
        self._offsets = {}  # result folder -> its projectors' refinement offsets (or None)

    @classmethod
    def from_capture(cls, setup_dir, working_size: int = DEFAULT_WORKING_SIZE, gammas=None) -> "JointShowSetup":
        """The capture of several projectors in setup_dir with its joint model (the first look fitted at the
        capture; fitted now where it is missing)."""
        from ..multi.capture_set import load_multi_capture
        from ..multi.first_look import fit_joint_first_look, load_joint_model

        cs = load_multi_capture(setup_dir, pairs=False)
        model = load_joint_model(cs.setup_dir)
        if model is None or model.count != cs.count:
            model = fit_joint_first_look(load_multi_capture(setup_dir)).model
        return cls(model, cs.together.astype(np.float32) / 255, cs.object_mask, working_size, gammas,
                   cs.meta.get("fingerprint"))

    def _camera_references(self, width: int, height: int) -> References:
        if (int(width), int(height)) != self.output_size:
            raise ShowError(f"a show of several projectors is made at the camera's {self.output_size[0]}x"
                            f"{self.output_size[1]}, not {width}x{height}: each projector's frame comes from it")
        from ..multi.joint_solve import reach

        return References(reach(self.model)[0], self.surface, self.surface, self.on)

    def offsets(self, result) -> list | None:
        """Refine on the Rig's correction of a result of several: each projector's refined image minus its
        open-loop one ((h_k,w_k,3) float32, in its frame), carried onto every frame of that look as one
        projector's show carries its offset; None for a result that was not refined (or cannot be read)."""
        key = str(result)
        if key not in self._offsets:
            self._offsets[key] = _refined_offsets(Path(key), self.model.count)
        return self._offsets[key]

    def project(self, target: np.ndarray, offsets: list | None = None) -> list:
        """(H,W,3) the frame's target in camera space -> each projector's frame (h_k,w_k,3) float32 encoded.
        Off the reach the target is the surface itself: nothing can change it there (multi/stylize)."""
        from ..multi.joint_solve import joint_compensate

        target = np.where(self.reached[..., None], target, self.surface).astype(np.float32)
        frames = joint_compensate(self.model, target, self.weights).frames
        if offsets is None:
            return frames
        return [np.clip(f + o, 0.0, 1.0).astype(np.float32) if o is not None and o.shape == f.shape else f
                for f, o in zip(frames, offsets)]


def _refined_offsets(folder: Path, count: int) -> list | None:
    from ..export.result_files import read_result_image, read_summary

    try:
        entries = read_summary(folder).get("projectors") or []
        if len(entries) != count or not all(e.get("image_open_loop") for e in entries):
            return None
        image = lambda name: read_result_image(folder, Path(name).stem)  # noqa: E731
        return [image(e["image"]) - image(e["image_open_loop"]) for e in entries]
    except (OSError, ValueError):
        return None


def working_size_of(summary: dict, default: int = DEFAULT_WORKING_SIZE) -> int:
    """The long side a result of several was made at (result.json's psa.working_size), else `default`."""
    psa = summary.get("psa")
    size = psa.get("working_size") if isinstance(psa, dict) else None
    return int(max(size)) if size else int(default)
