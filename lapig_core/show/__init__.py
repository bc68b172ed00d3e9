# SPDX-License-Identifier: GPL-3.0-or-later
"""A show: looks held, dissolved, morphed and moving over time, every frame compensated (issue 38). bpy-free.

The API the add-on (branch `showaddon`) and the video export (branch `video`) call:

    from lapig_core.show import (Show, Look, Motion, Transition, ShowError, schedule_of, show_frames,
                                 ShowSetup)

    show = Show(looks=[Look(result="/data/results/2026-.._stained_glass", prompt="stained glass",
                            backend="styletransfer", seed=0, hold_s=2.0),
                       Look(result="/data/results/2026-.._ink_wash", prompt="ink wash", backend="styletransfer",
                            seed=3, hold_s=4.0, motion=Motion("drift", amount=0.5, period_s=4.0))],
                transitions=[Transition("morph", seconds=1.5)],   # len(looks) - 1 of them
                fps=30.0)
    show.validate()                       # ShowError(ValueError) with one clear line
    d = show.to_dict(); Show.from_dict(d) # plain JSON (the export sidecar lists this dict under "show")

    sched = schedule_of(show)             # show/schedule.py
    sched.total_frames                    # int
    sched.at(i)                           # FrameKey: ('hold', i, 0.0) | ('dissolve', i, j, w) |
                                          #           ('morph', i, j, w) | ('moving', i, t)
                                          # equal keys = the same frame (holds are made once)

    setup = ShowSetup.from_capture(setup_dir)   # the capture's SurfaceModels: Train's saved models, else its
                                                # first look (the classical model); ShowError when neither
    # or ShowSetup(models, load_look=None, setup_dir=None, dark_outside=False, references=None, fingerprint=None):
    #   load_look(look, models) -> KeyedLook (default look_from_result: the result folder's result.json,
    #   its look_state.npz or PSA once); references(w, h) -> References at another output size
    #   (default: the capture's, registered there); fingerprint: the capture's, so a look whose result was
    #   made on another capture (stale) is refused with a ShowError
    for index, frame in show_frames(show, setup, size=None, cancel_event=None, on_progress=None):
        ...   # frame: float32 (H, W, 3) in [0, 1], the projector image; size=None: the working frame,
              # size=(width, height): that size as native_output makes it (e.g. the projector's native frame)

    show_frames(show, setup, *, size=None, cancel_event=None, on_progress=None, start=0, stop=None,
                settings=None) -> Iterator[tuple[int, np.ndarray]]
        setup: a ShowSetup or a capture's folder. Frames in order from `start` to `stop` (exclusive; None:
        the end). cancel_event: a threading.Event; once set, InterruptedError before the next frame (it only
        yields, it writes nothing: the caller drops what it has). on_progress(p, message) after each frame,
        p in (0, 1] over the frames asked for (p = 0 with "preparing look n" while the keyed looks are made).
        ShowError for a bad show. settings: FrameSettings (the per-frame adaptation's steps and pulls; the
        dissolve's gamma: pass the projector's, default 2.2; dissolve="crossfade" (default, the fast path) or
        "compensated": each dissolve frame's linear-light mix of the targets compensated).
        Frames repeat as the schedule's keys do (holds are compensated once; keep one generator per run).

    FrameMaker(show, setup, size=None, settings=None, cancel_event=None)   the producer show_frames drives:
        .frame(key) -> np.ndarray, .target_of(key) -> (1,3,H,W) tensor (for measures), .schedule, .computed
    keyed_look_from_prompt(models, prompt, backend, seed=0, mix=None, psa=True, psa_settings=None, state=None)
        -> KeyedLook: a look made as Generate makes it (for a look not yet saved as a result)
    save_look_state(folder, state) / load_look_state(folder): look_state.npz beside result.json (optional)
    refine_offset(folder): a refined result's correction (refined minus open-loop projector image), which
        look_from_result puts on KeyedLook.offset and every frame of that look carries (a morph: mixed by w)

Modules, one concept each:
    model.py      Show, Look, Motion, Transition, ShowError: the data, its validation, to_dict/from_dict
    schedule.py   frame index -> FrameKey; the total frame count
    motion.py     the motion presets (drift, rise, pulse, colour_cycle) as smooth periodic functions of time
    morph.py      between two looks: theta interpolated where both share a backend and theta's shapes,
                  else their targets mixed in linear light and adapted as one look
    look_state.py a look's state (theta and its PSA tone field) saved with a result as look_state.npz,
                  read with allow_pickle=False; results without it are re-prepared and adapted once
    frames.py     the per-frame producer: show_frames, ShowSetup, FrameSettings
"""

from .model import MOTION_PRESETS, TRANSITION_KINDS, Look, Motion, Show, ShowError, Transition
from .schedule import Schedule, schedule_of

_LAZY = {"show_frames": "frames", "ShowSetup": "frames", "FrameSettings": "frames", "FrameMaker": "frames",
         "look_from_result": "frames", "keyed_look_from_prompt": "frames", "KeyedLook": "look_state",
         "save_look_state": "look_state", "load_look_state": "look_state", "refine_offset": "look_state",
         "apply_motion": "motion"}


def __getattr__(name):
    """The torch-side names on first use: the model and the schedule import no torch (a panel can read a
    show without loading it)."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["Look", "MOTION_PRESETS", "Motion", "Schedule", "Show", "ShowError", "TRANSITION_KINDS", "Transition",
           "schedule_of", *_LAZY]
