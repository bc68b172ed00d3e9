# SPDX-License-Identifier: GPL-3.0-or-later
"""The per-frame producer: every frame of a show, compensated, as the projector shows it.

    hold       the keyed look (its theta and PSA's tone field), compensated once and kept
    moving     the keyed look's image moved (motion.py), adapted, compensated
    morph      the in-between image (morph.py), adapted, compensated
    dissolve   by default ("keyed") the two targets' linear-light mix compensated at a few key weights
               (1/4, 1/2, 3/4) and the frames between two keys their linear-light crossfade; "compensated"
               compensates every frame, "crossfade" none (the looks' compensated frames blended)

Why keyed: the crossfade of the two compensated looks is 4.7 dB worse at a dissolve's midpoint than the
midpoint's own compensation on a Cycles-rendered panel (bench show: dissolve_check_db, 24.4 against 29.1 dB):
where a look lies partly outside the surface's reach its compensation clips, and the mix of two clipped frames
is not the compensation of the mix, which often lies inside the reach. Compensating every frame costs a
compensation per frame (about 1 s at 1920x1080 on 2 cores, against 35 crossfades a second); between keys a
quarter of the dissolve apart the compensation is close to linear, so keys keep the midpoint's own quality at
a few compensations per dissolve.

Adapting a new frame is PSA's fast path only: the tone field (psa/tone_field), warm-started from the
previous frame's correction, a few Adam steps on PSA's warm-start objective (psa/adaptation: the classical
proxy loss, no network, milliseconds; the style and keep-light terms against the frame's own image), with
two pulls: towards the warm start (consecutive frames' fields stay close: no flicker) and towards the keyed
look's own field (no slow drift off what PSA chose). One optimiser is carried from frame to frame, its
moments too, and the best iterate is kept, the warm start included: Adam's normalised step moves every
parameter by about its whole step even at the optimum, which would shake the field every frame. theta is not
optimised per frame: each joint step runs the networks' backward (about 0.6 s at 256x192 on 2 cores,
PSASettings), where the field's proxy steps cost milliseconds; the keyed looks had full PSA.

Compensation is the setup's chosen compensator (the per-pixel classical solve where Train chose it, or the
first look's; CompenNeSt's inference otherwise) through native_output.compensate_frame, tiled for memory.
At another size (size=(w, h)) the look is rendered there as the native output does (registered
references, render_at, the field with the working frame's guide) and compensated there.
"""
from __future__ import annotations

import contextlib
import dataclasses
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..common.adam import Adam
from ..export.projector_image import blend_linear_light
from ..native_output import compensate_frame, device_tile
from ..psa.adaptation import PSASettings, _style_loss, keep_light_loss, proxy_psa_loss, run_psa
from ..psa.tone_field import AdaptedLook, ToneField
from .look_state import KeyedLook, load_look_state, read_result_record, refine_offset, result_geometry
from .model import Show, ShowError
from .morph import lerp_list, mix_linear, morph_base
from .motion import apply_motion
from .schedule import Schedule, schedule_of


DISSOLVES = ("keyed", "compensated", "crossfade")
DISSOLVE_KEYS = (0.25, 0.5, 0.75)  # the keyed dissolve's compensated weights between its two ends


def key_span(w: float, keys=DISSOLVE_KEYS) -> tuple[float, float]:
    """The keyed dissolve's keys on either side of its weight w (0 and 1: the looks themselves)."""
    w = float(w)
    return max([0.0] + [k for k in keys if k <= w]), min([1.0] + [k for k in keys if k > w])


@dataclass
class FrameSettings:
    field_steps: int = 3  # Adam steps of the tone field per adapted frame
    field_lr: float = 0.01
    temporal_weight: float = 10.0  # the pull towards the warm start (the previous frame's correction)
    keyed_weight: float = 2.0  # the pull towards the keyed look's own field (no slow drift away from it)
    psa: PSASettings | None = None  # the style and keep-light terms' settings (None: PSA's defaults)
    adapt: bool = True  # False: moved / morphed looks through the interpolated field, not adapted
    cache_frames: int = 16  # the newest frames kept besides the holds (a periodic motion's repeats)
    gamma: float = 2.2  # dissolves' projector transfer (ProjectorModel.gamma; crossfade_sequence's default)
    # 'keyed': the mixed targets compensated at DISSOLVE_KEYS and crossfaded between them (the module's
    # docstring says why); 'compensated': every frame's mixed target compensated; 'crossfade': the
    # linear-light blend of the two looks' compensated frames (no compensation per frame)
    dissolve: str = "keyed"


class ShowSetup:
    """What a show is made on: one setup's SurfaceModels and the way to its keyed looks.

    models: SurfaceModels (pipeline.surface_models or first_look_models). load_look(look, models) ->
    KeyedLook; default: look_from_result (the result folder). setup_dir: the capture, for another output
    size (its registered references). dark_outside: projector pixels off the object black.
    references(width, height) -> capture.native_references.References: the surface at another output size
    (default: the capture's references registered there)."""

    def __init__(self, models, load_look=None, setup_dir=None, dark_outside: bool = False, references=None,
                 fingerprint: str | None = None):
        self.models = models
        self.fingerprint = fingerprint  # the capture's (setup.json): a look made on another one is refused
        self.load_look = load_look or look_from_result
        self.setup_dir = Path(setup_dir) if setup_dir is not None else None
        self.dark_outside = dark_outside
        self._references = references
        self._looks = {}
        self.look_surface = None  # (1,3,H,W): the white-lit surface the looks' backends are prepared on (None: I+)

    def references(self, width: int, height: int):
        if self._references is not None:
            return self._references(width, height)
        from ..capture.native_references import registered_references

        if self.setup_dir is None:
            raise ShowError("an output size other than the working frame needs the capture's folder")
        return registered_references(self.setup_dir, width, height)

    @classmethod
    def from_capture(cls, setup_dir, device=None, dark_outside: bool = True) -> "ShowSetup":
        """The capture's saved models (Train's), else its first look (the classical model)."""
        from ..capture.dataset import load_capture_set
        from ..photometric.first_look import load_first_look
        from .. import pipeline

        cs = load_capture_set(setup_dir)
        problem, saved = pipeline.saved_models_problem(setup_dir)
        if saved is not None:
            models = pipeline.surface_models(cs, train_if_missing=False, saved=saved, device=device)
        else:
            look = load_first_look(setup_dir, cs.meta.get("fingerprint"))
            if look is None:
                raise ShowError(f"{setup_dir} has neither trained models nor a first look ({problem}): "
                                "capture it again")
            models = pipeline.first_look_models(cs, look.classical, device=device)
        dark = dark_outside and pipeline.object_footprint(cs) is not None
        return cls(models, setup_dir=setup_dir, dark_outside=dark, fingerprint=cs.meta.get("fingerprint"))

    def keyed(self, index: int, look, cancel_event=None) -> KeyedLook:
        """Look `index` of the show as PSA left it, made once for this setup (kept by what makes it: the
        result folder, prompt, backend and seed, so an edited show reuses the looks it still has). A look
        whose making was cancelled (PSA stops at the cancel with its best iterate so far) is not kept:
        InterruptedError."""
        key = (str(look.result), look.prompt, look.backend, int(look.seed))
        if key not in self._looks:
            if self.load_look is look_from_result:
                keyed = look_from_result(look, self.models, cancel_event=cancel_event, fingerprint=self.fingerprint,
                                         surface=self.look_surface)
            else:
                keyed = self.load_look(look, self.models)
            if cancel_event is not None and cancel_event.is_set():
                raise InterruptedError("the show was cancelled")
            self._looks[key] = keyed
        return self._looks[key]


def _psa_settings(recorded: dict, seed: int) -> PSASettings:
    known = {f.name for f in dataclasses.fields(PSASettings)}
    values = {k: v for k, v in (recorded or {}).items() if k in known}
    if "terms" in values:
        values["terms"] = tuple(values["terms"])
    values.setdefault("seed", seed)
    return PSASettings(**values)


def look_from_result(look, models, cancel_event=None, fingerprint: str | None = None, surface=None) -> KeyedLook:
    """A keyed look from its result folder (look_state docstring): the backend prepared from result.json's
    prompt, backend, seed and mix on the white-lit surface; theta and the tone field from look_state.npz,
    else from PSA run again with the recorded settings. A Look whose folder does not exist is made from its
    own prompt, backend and seed. fingerprint: the capture's; a result made on another capture (a stale look)
    is refused with one line. surface: what the backend is prepared on (keyed_look_from_prompt)."""
    folder = Path(look.result)
    if (folder / "result.json").is_file():
        record = read_result_record(folder)
        if fingerprint and record.get("fingerprint") and record["fingerprint"] != fingerprint:
            raise ShowError(f"the look '{record['prompt'] or folder.name}' was made on another capture of the rig "
                            f"({folder.name}): generate it again on this capture")
    elif folder.exists() or not look.prompt:
        raise ShowError(f"the look's result {folder} has no result.json: choose a result Generate wrote")
    else:
        record = {"prompt": look.prompt, "backend": look.backend, "seed": look.seed, "mix": None, "psa": True,
                  "psa_settings": {}}
    state = load_look_state(folder) if folder.exists() else None
    geometry = result_geometry(folder, record) if folder.exists() else None  # shaped as the still look was
    keyed = keyed_look_from_prompt(models, record["prompt"], record["backend"], record["seed"], record["mix"],
                                   psa=record["psa"],
                                   psa_settings=_psa_settings(record["psa_settings"], record["seed"]),
                                   state=state, cancel_event=cancel_event, surface=surface, geometry=geometry,
                                   look_parameters=record.get("look_parameters"))
    keyed.offset = refine_offset(folder) if folder.exists() else None
    if keyed.offset is not None and tuple(keyed.offset.shape[-2:]) != tuple(models.s.shape[-2:]):
        keyed.offset = None  # refined at another working frame: not this capture's correction
    return keyed


def keyed_look_from_prompt(models, prompt: str, backend: str, seed: int = 0, mix=None, psa: bool = True,
                           psa_settings: PSASettings | None = None, state: dict | None = None,
                           cancel_event=None, surface: torch.Tensor | None = None, geometry=None,
                           look_parameters: dict | None = None) -> KeyedLook:
    """The look of a prompt on this surface as Generate makes it: the backend prepared on the white-lit
    surface (`surface`, (1,3,H,W) at the working frame; default the models' I+), then `state` loaded (theta and
    the tone field) or PSA run with `psa_settings`. geometry: what a look of the world is shaped by, as
    pipeline.stylize takes it (a LookGeometry, "capture" or None); look_parameters: a world look's edited sliders
    (result.json's)."""
    from ..lgst import DEFAULT_BACKEND, prepared_backend
    from ..pipeline import with_device

    options = with_device(backend, {"look_parameters": look_parameters}
                          if look_parameters and backend == DEFAULT_BACKEND else None, models.device)
    surface = models.i_max if surface is None else surface
    if geometry is not None and backend == DEFAULT_BACKEND and not mix:
        from ..lgst.world.geometry import from_capture

        options["geometry"] = from_capture(surface[0].permute(1, 2, 0).cpu().numpy()) \
            if isinstance(geometry, str) else geometry
    lgst, _ = prepared_backend(backend, surface, prompt, seed=seed, mix=mix, options=options)
    adapted = AdaptedLook(lgst, models.i_min, models.i_max)
    if state is None:
        settings = psa_settings or PSASettings(seed=seed)
        state = run_psa(adapted, models, settings, cancel_event=cancel_event).state if psa else adapted.state()
    adapted.load_state({**lgst.state(), **{k: [t.to(models.device) for t in v] for k, v in state.items()
                                           if k in ("theta", "tone_field")}})
    with torch.no_grad():
        base = lgst.forward().detach()
    return KeyedLook(lgst, adapted.state(), base, getattr(lgst, "name", ""))


@contextlib.contextmanager
def world_time(keyed: KeyedLook, motion, t: float, index: int = 0):
    """The keyed world look's stage set to time `t` of `motion` for a moment (the 'world' motion: the look's own
    time, water flowing, fire flickering; amount 0.5 runs at the look's Speed slider, 1 twice as fast)."""
    from ..lgst.world.moving import Clock

    controls = keyed.backend.world_controls() if hasattr(keyed.backend, "world_controls") else None
    if controls is None:
        raise ShowError(f"look {index + 1}: the 'world' motion moves a look of the world (a material, a plant, "
                        "water, fire, the sky); give this look another motion")
    controls.clock = Clock(float(t), float(motion.period_s), controls.look.speed * 2.0 * float(motion.amount))
    try:
        yield
    finally:
        controls.clock = None


@contextlib.contextmanager
def _nothing():
    yield


def _as_frame(t: torch.Tensor) -> np.ndarray:
    return t.detach()[0].permute(1, 2, 0).clamp(0, 1).cpu().numpy().astype(np.float32)


def _mixed_offset(a, b, w: float):
    """Two looks' refinement offsets mixed at weight w (a missing one counts as none); tensors, or for several
    projectors lists of per-projector arrays (an entry may be None)."""
    if a is None and b is None:
        return None
    if isinstance(a, list) or isinstance(b, list):
        pairs = zip(a or [None] * len(b), b or [None] * len(a))
        return [None if x is None and y is None else
                (1.0 - w) * (x if x is not None else 0.0) + w * (y if y is not None else 0.0) for x, y in pairs]
    zero = torch.zeros_like(a if a is not None else b)
    return (1.0 - w) * (a if a is not None else zero) + w * (b if b is not None else zero)


def _blend(a: np.ndarray, b: np.ndarray, w: float, gamma: float) -> np.ndarray:
    """Two encoded projector frames mixed at weight w in the projector's linear light (transfer `gamma`)."""
    g = np.float32(gamma)
    return blend_linear_light(a, b, np.power(a, g), np.power(b, g), w, float(g)).astype(np.float32)


class FrameMaker:
    """Frames by key (schedule.py), cached: holds for the whole run, the newest others in a small LRU."""

    def __init__(self, show: Show, setup: ShowSetup, size=None, settings: FrameSettings | None = None,
                 cancel_event=None):
        self.show, self.setup = show, setup
        self.schedule: Schedule = schedule_of(show)
        self.settings = settings or FrameSettings()
        if self.settings.dissolve not in DISSOLVES:
            raise ShowError(f"a dissolve is made as one of {', '.join(DISSOLVES)}, not '{self.settings.dissolve}'")
        self.cancel_event = cancel_event
        models = setup.models
        self.models = models
        self.field = ToneField(models.i_min, models.i_max)
        for p in self.field.parameters():
            p.requires_grad_(True)
        self.optimiser = Adam(list(self.field.parameters()), lr=self.settings.field_lr)
        self.carry = None  # the previous adapted frame's correction of its field (warm start)
        self.psa_settings = self.settings.psa or PSASettings()
        # the projector's own transfer, not the classical fit's gamma_p: that one trades off against M and
        # the camera's gamma (the device check's fake rig is 2.2 / 2.2; its fit says 1.37 / 1.61)
        self.gamma = float(self.settings.gamma)
        self._kept, self._recent = {}, OrderedDict()
        self.computed = 0  # frames made (not from the cache)
        self._params = {}  # the field's parameters each adapted key was made with (target_of reads them)
        # a setup of several projectors (joint_setup.JointShowSetup) makes each frame in camera space at its
        # output size and turns it into one frame per projector (setup.project); its dissolves mix each
        # projector's frame in that projector's linear light (setup.gammas)
        self.joint = getattr(setup, "project", None) is not None
        if size is None and self.joint:
            size = setup.output_size
        self._size_refs(size)

    def _size_refs(self, size):
        """The references at the output size (None: the working frame's)."""
        working = tuple(self.models.s.shape[-2:])  # (H, W)
        self.native = size is not None and (int(size[1]), int(size[0])) != working
        self.valid = self.models.on_object if self.setup.dark_outside else None
        self.s, self.white = self.models.s, None
        height, width = working
        if self.native:
            from ..photometric.training_data import to_tensor

            width, height = int(size[0]), int(size[1])
            refs = self.setup.references(width, height)
            device = self.models.device
            self.s, self.white = to_tensor(refs.gray).to(device), to_tensor(refs.white).to(device)
            self.valid = (torch.from_numpy(refs.valid)[None, None].to(device=device, dtype=torch.float32)
                          if self.setup.dark_outside else None)
            self._native_bases = {}
        self.tile = device_tile(width, height, self.models.device)

    # ------------------------------------------------------------------ looks
    def keyed(self, i: int) -> KeyedLook:
        return self.setup.keyed(i, self.show.looks[i], self.cancel_event)

    def looks_of(self, start: int, stop: int) -> list:
        """The indices of the looks frames start..stop-1 need, in order of first use."""
        needed = []
        for seg in self.schedule.segments:
            if seg.first < stop and seg.first + seg.frames > start:
                needed += [i for i in seg.looks if i not in needed]
        return needed

    def base(self, i: int) -> torch.Tensor:
        """Look i's image before its field, at the output size."""
        look = self.keyed(i)
        if not self.native:
            return look.base
        if i not in self._native_bases:
            with torch.no_grad():
                self._native_bases[i] = look.backend.render_at(self.white).detach()
        return self._native_bases[i]

    def end_key(self, i: int) -> tuple:
        """The key a transition out of look i stands on."""
        if self.show.looks[i].motion is None:
            return ("hold", i, 0.0)
        return ("moving", i, self.schedule.hold_end_t(i))

    def start_key(self, j: int) -> tuple:
        return ("hold", j, 0.0) if self.show.looks[j].motion is None else ("moving", j, 0.0)

    # ------------------------------------------------------------------ adaptation
    def _load_field(self, params):
        with torch.no_grad():
            for p, v in zip(self.field.parameters(), params):
                p.copy_(v.to(p.device))

    def adapt(self, working_base: torch.Tensor, init: list) -> list:
        """The field's parameters for this frame's image (working frame): warm-started, a few steps, the
        best iterate kept (the warm start included): Adam's normalised step moves a parameter by about its
        whole step even at the optimum, so only a step that lowers the loss is taken, and a frame whose
        warm start is already best keeps it (no shake)."""
        s = self.settings
        warm = [v + c for v, c in zip(init, self.carry)] if self.carry is not None else [v.clone() for v in init]
        self._load_field(warm)
        params = [v.clone() for v in warm]
        if s.adapt and s.field_steps > 0:
            params = self._descend(working_base.detach(), warm, init)
        self._load_field(params)
        self.carry = [p - v for p, v in zip(params, init)]
        return params

    def _descend(self, base: torch.Tensor, warm: list, init: list) -> list:
        s, ps = self.settings, self.psa_settings
        _, _, style_weight = ps.style_mix()
        with torch.no_grad():  # the frame's own scale, as PSA's warm start takes it (psa/adaptation)
            scale = max(float(proxy_psa_loss(base, self.models, ps)), 1e-6)
        best = None
        for step in range(s.field_steps + 1):
            if self.cancel_event is not None and self.cancel_event.is_set():
                break
            adapted = self.field.apply(base)
            # PSA's warm-start objective on this frame's image (the keyed look's field is its optimum)...
            loss = proxy_psa_loss(adapted, self.models, ps) + style_weight * scale * (
                _style_loss(adapted, base, None, ps)
                + ps.keep_light_weight * keep_light_loss(adapted, base, self.models))
            # ...the pull towards the warm start (consecutive frames' fields stay close), and towards the keyed
            # look's field (the look does not drift off what PSA chose); relative to the frame's proxy loss,
            # as PSA's style term is
            pull = sum(((p - w) ** 2).sum() for p, w in zip(self.field.parameters(), warm))
            keep = sum(((p - v) ** 2).sum() for p, v in zip(self.field.parameters(), init))
            loss = loss + scale * (s.temporal_weight * pull + s.keyed_weight * keep)
            value = float(loss.detach())
            if best is None or value < best[0]:
                best = (value, [p.detach().clone() for p in self.field.parameters()])
            if step == s.field_steps:
                break
            self.optimiser.zero_grad(set_to_none=True)
            loss.backward()
            self.optimiser.step()
        return best[1] if best is not None else [v.clone() for v in warm]

    def _field_of(self, i: int) -> list:
        return [t.to(self.models.device) for t in self.keyed(i).state["tone_field"]]

    # ------------------------------------------------------------------ frames
    def _offset(self, i: int):
        """Look i's refinement offset at the output size, or None (several projectors: one per projector, in
        each one's frame)."""
        if self.joint:
            return self.setup.offsets(self.show.looks[i].result)
        offset = self.keyed(i).offset
        if offset is None:
            return None
        size = tuple(self.s.shape[-2:])
        offset = offset.to(self.s.device)
        if tuple(offset.shape[-2:]) != size:
            offset = torch.nn.functional.interpolate(offset, size=size, mode="bilinear", align_corners=False)
        return offset

    def offset_of(self, key: tuple):
        """The refinement offset a frame carries: its look's; a morph's the two looks' mixed by w."""
        if key[0] in ("hold", "moving"):
            return self._offset(key[1])
        if key[0] == "morph":
            return _mixed_offset(self._offset(key[1]), self._offset(key[2]), key[3])
        return None

    def _compensate(self, base: torch.Tensor, params: list, offset=None):
        self._load_field(params)
        with torch.no_grad():
            target = self.field.apply(base)
        return self._project(target, offset)

    def _project(self, target: torch.Tensor, offset=None):
        """The frame that shows `target` (1,3,H,W) at the output size: the projector frame (H, W, 3), or with a
        setup of several projectors the list of their frames (the joint solve; no refinement offset)."""
        self.computed += 1
        if self.joint:
            return self.setup.project(_as_frame(target), offset)
        with torch.no_grad():
            projector = compensate_frame(self.models.compensator, target, self.s, self.tile)
            if offset is not None:
                projector = (projector + offset).clamp(0, 1)
            if self.valid is not None:
                projector = projector * self.valid
        return _as_frame(projector)

    def _crossfade(self, a, b, w: float):
        """Frames a and b mixed at weight w in the projector's linear light (each projector's, for several)."""
        if self.joint:
            return [_blend(fa, fb, w, g) for fa, fb, g in zip(a, b, self.setup.gammas)]
        return _blend(a, b, w, self.gamma)

    def target_of(self, key: tuple) -> torch.Tensor:
        """The frame's target at the output size, as its frame was made (for measures)."""
        base, params = self._recipe(key, adapt=False)
        self._load_field(params)
        with torch.no_grad():
            return self.field.apply(base)

    def _recipe(self, key: tuple, adapt: bool = True):
        """(the image before the field at the output size, the field's parameters) of a key."""
        kind = key[0]
        if kind == "hold":
            return self.base(key[1]), self._field_of(key[1])
        if kind == "moving":
            i, t = key[1], key[2]
            motion = self.show.looks[i].motion
            params = self._params.get(key) if not adapt else None
            if params is None:
                working = self._moved(i, t, at_output=False)
                params = self.adapt(working, self._field_of(i)) if adapt else self._field_of(i)
            return self._moved(i, t, at_output=True), params
        if kind == "morph":
            i, j, w = key[1], key[2], key[3]
            params = self._params.get(key) if not adapt else None
            working = None
            if params is None:
                init = lerp_list(self._field_of(i), self._field_of(j), w)
                working = self._morph_image(i, j, w, None) if adapt else None
                params = self.adapt(working, init) if adapt else init
            if self.native:
                return self._morph_image(i, j, w, self.white), params
            return (working if working is not None else self._morph_image(i, j, w, None)), params
        raise ShowError(f"no recipe for a {kind} frame")

    def _moved(self, i: int, t: float, at_output: bool) -> torch.Tensor:
        """Look i's image moved to `t` seconds, at the working frame or at the output size: a world look drawn
        again at that time (the 'world' motion), any other look's image moved by its preset."""
        motion = self.show.looks[i].motion
        if motion.preset != "world":
            return apply_motion(self.base(i) if at_output else self.keyed(i).base, motion, t)
        keyed = self.keyed(i)
        with world_time(keyed, motion, t, i):
            with torch.no_grad():
                return (keyed.backend.render_at(self.white) if at_output and self.native
                        else keyed.backend.forward()).detach()

    def _morph_image(self, i, j, w, surface):
        """The in-between image; a moving look stands where its hold leaves it (look i at the end of its hold,
        look j at its start), so the morph starts and lands on the frames beside it."""
        end_t = self.schedule.hold_end_t(i)
        motion_a, motion_b = self.show.looks[i].motion, self.show.looks[j].motion
        world_a = motion_a is not None and motion_a.preset == "world"
        move_a = (lambda x: apply_motion(x, motion_a, end_t)) if motion_a and not world_a else None
        move_b = (lambda x: apply_motion(x, motion_b, 0.0)) if motion_b and motion_b.preset != "world" else None
        native = surface is not None
        base_a = self._moved(i, end_t, at_output=True) if world_a and native else (self.base(i) if native else None)
        with world_time(self.keyed(i), motion_a, end_t, i) if world_a else _nothing():  # a world look at its end
            return morph_base(self.keyed(i), self.keyed(j), w, surface, base_a=base_a,
                              base_b=self.base(j) if native else None, move_a=move_a, move_b=move_b)

    def _compensated_dissolve(self, key: tuple) -> np.ndarray:
        """The dissolve's frame compensated as a target of its own: the two ends' targets mixed in linear
        light (what an ideal dissolve shows), compensated, with the ends' offsets mixed. Where a look lies
        outside the surface's reach, the mix often lies inside it, which the crossfade of the clipped
        compensated frames cannot use (bench show: dissolve_check_db)."""
        i, j, w = key[1], key[2], key[3]
        ka, kb = self.end_key(i), self.start_key(j)
        self.frame(ka), self.frame(kb)  # the ends first: a moving end's field is adapted in its order
        with torch.no_grad():
            target = mix_linear(self.target_of(ka), self.target_of(kb), float(w))
        return self._project(target, _mixed_offset(self.offset_of(ka), self.offset_of(kb), w))

    def _dissolve_ends(self, key: tuple) -> tuple:
        """The two frames a dissolve frame is crossfaded between, with their weights: the looks' own frames
        for "crossfade"; for "keyed", the nearest compensated keys (DISSOLVE_KEYS) on either side."""
        i, j = key[1], key[2]
        wa, wb = key_span(key[3], DISSOLVE_KEYS if self.settings.dissolve == "keyed" else ())
        a = self.frame(self.end_key(i)) if wa == 0.0 else self.frame(("dissolve_key", i, j, wa))
        b = self.frame(self.start_key(j)) if wb == 1.0 else self.frame(("dissolve_key", i, j, wb))
        return (wa, a), (wb, b)

    def frame(self, key: tuple) -> np.ndarray:
        """The projector frame (H, W, 3) float32 of a key, from the cache where it was made before."""
        if key in self._kept:
            return self._kept[key]
        if key in self._recent:
            self._recent.move_to_end(key)
            return self._recent[key]
        if key[0] == "dissolve_key" or (key[0] == "dissolve" and self.settings.dissolve == "compensated"):
            out = self._compensated_dissolve(key)
        elif key[0] == "dissolve":
            (wa, a), (wb, b) = self._dissolve_ends(key)
            out = self._crossfade(a, b, (float(key[3]) - wa) / (wb - wa))
            self.computed += 1
        else:
            base, params = self._recipe(key)
            self._params[key] = params
            out = self._compensate(base, params, self.offset_of(key))
        if key[0] == "hold" or key in (self.end_key(key[1]),) or (key[0] == "moving" and key[2] == 0.0):
            self._kept[key] = out  # holds and the transitions' ends: for the whole run
        else:
            self._recent[key] = out
            while len(self._recent) > self.settings.cache_frames:
                self._recent.popitem(last=False)
        return out


def show_frames(show: Show, setup, *, size=None, cancel_event=None, on_progress=None, start: int = 0,
                stop: int | None = None, settings: FrameSettings | None = None):
    """Yield (frame index, projector frame float32 (H, W, 3) in [0, 1]) from `start` to `stop` (exclusive).

    setup: a ShowSetup, or a capture's folder (ShowSetup.from_capture). size: None for the working frame,
    or (width, height). A set cancel_event raises InterruptedError before the next frame (nothing is written:
    the caller discards what it has). on_progress(p, message) after every frame."""
    if not isinstance(setup, ShowSetup):
        setup = ShowSetup.from_capture(setup)
    maker = FrameMaker(show, setup, size, settings, cancel_event)
    total = maker.schedule.total_frames
    stop = total if stop is None else min(int(stop), total)
    if not 0 <= start <= stop:
        raise ShowError(f"frames {start} to {stop} are outside the show's {total} frames")
    looks = maker.looks_of(start, stop)
    for n, i in enumerate(looks, 1):  # the keyed looks first (PSA where no state is saved: seconds each)
        if cancel_event is not None and cancel_event.is_set():
            raise InterruptedError("the show was cancelled")
        if on_progress:
            on_progress(0.0, f"preparing look {i + 1} ({n} of {len(looks)})")
        maker.keyed(i)
    for index in range(start, stop):
        if cancel_event is not None and cancel_event.is_set():
            raise InterruptedError("the show was cancelled")
        key = maker.schedule.at(index)
        frame = maker.frame(key)
        if cancel_event is not None and cancel_event.is_set():
            raise InterruptedError("the show was cancelled")
        if on_progress:
            on_progress((index - start + 1) / max(stop - start, 1), f"frame {index + 1} of {total} ({key[0]})")
        yield index, frame
