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

    setup = ShowSetup.from_capture(setup_dir)   # the capture's SurfaceModels (saved models or the first look)
    for index, frame in show_frames(show, setup, size=None, cancel_event=None, on_progress=None):
        ...   # frame: float32 (H, W, 3) in [0, 1], the projector image; size=None: the working frame,
              # size=(width, height): that size through native_output (e.g. the projector's native frame)

    show_frames(show, setup, *, size=None, cancel_event=None, on_progress=None, start=0, stop=None,
                settings=None) -> Iterator[tuple[int, np.ndarray]]
        frames in order from `start` to `stop` (exclusive; None: the end). cancel_event: a threading.Event;
        when set, the iterator stops before the next frame (nothing is written anywhere: it only yields).
        on_progress(p, message): p in [0, 1] over the frames asked for. Raises ShowError for a bad show.

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
