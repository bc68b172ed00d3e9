# SPDX-License-Identifier: GPL-3.0-or-later
"""A real rig of several projectors: K projector outputs (one window per display, each its own helper
process) and ONE camera, as the MultiProjectorDevice the capture of several projectors drives
(lapig_core/multi/capture).

Each projector is calibrated as a rig of one (lapig_core.rig.rig_device.RigDevice) through ``SoloOutput``:
its output shows the frame, every other output shows black. So each projector gets its own latency, its own
frame code's cells in the camera and its own health checks, measured with only that projector lit, and its
Gray code and training frames are shot through its own FrameSync (verified grabs), the others black.

A frame set with several projectors lit (all black, all white together, refinement's rounds) is shown on
every output at once, each frame stamped with one shared sequence number in one of its code bands (neighbours
alternate: top, bottom; the other band black, so one projector's code never lights another's cells), and a
grab is kept only when every projector whose code the camera reads reads that number: a window that presented
late is caught as it would be alone.

``simulated_multi_rig`` puts K SimulatedScreens and one SimulatedCamera around any MultiProjectorDevice as
the optics (the numpy FakeRigDevice, or the Cycles studio of several): the camera sees the sum of the K
screens' light, each at the moment the camera exposes, with the single rig's latency and faults.
"""
from __future__ import annotations

from collections import Counter
from typing import Sequence

import numpy as np

from ..capture.settings import CaptureError
from ..common.imageio import to_uint8
from ..multi.capture import MultiDeviceInfo, MultiProjectorDevice
from . import RigError
from . import frame_code as fc
from .clock import REAL_CLOCK
from .simulated import CameraFaults, SimulatedCamera, SimulatedScreen


def _black(size) -> np.ndarray:
    w, h = size
    return np.zeros((h, w, 3), np.uint8)


class SoloOutput:
    """Projector k of several as a ProjectorOutput of its own: show() lights it, every other output black."""

    def __init__(self, outputs: Sequence, k: int):
        self.outputs, self.k = list(outputs), k
        self.size = tuple(outputs[k].size)
        self._others_black = False

    def show(self, frame) -> float:
        if not self._others_black:  # black once: they stay black while this one is shot
            for j, out in enumerate(self.outputs):
                if j != self.k:
                    out.show(_black(out.size))
            self._others_black = True
        return self.outputs[self.k].show(frame)

    def release(self) -> None:
        """Another output will show something: black them again before this one's next frame."""
        self._others_black = False

    def describe(self) -> dict:
        return self.outputs[self.k].describe()

    def close(self) -> None:  # the multi rig closes every output once
        pass


class _SharedCamera:
    """The one camera lent to each projector's RigDevice: their close() does not close it."""

    def __init__(self, camera):
        self._camera = camera

    def __getattr__(self, name):
        return getattr(self._camera, name)

    def close(self) -> None:
        pass


class MultiRigDevice(MultiProjectorDevice):
    """K outputs (ProjectorWindow or SimulatedScreen) and one camera; names: the projectors', in order.
    object_mask: where the camera sees the object, where the rig knows it (a simulated one); None otherwise.
    projector_details: what each projector's optics record (gamma, black level), merged into setup.json."""

    main_thread = False

    def __init__(self, outputs: Sequence, camera, names: Sequence[str] | None = None, name: str = "real rig",
                 clock=REAL_CLOCK, frame_code: bool = True, health_checks: bool = True, max_grabs: int = 8,
                 object_mask=None, projector_details: Sequence[dict] | None = None):
        from .rig_device import RigDevice

        if len(outputs) < 1:
            raise RigError("a rig of several projectors needs at least one projector output")
        self.outputs, self.camera, self.clock, self.name = list(outputs), camera, clock, name
        self._named = bool(names)
        self.names = list(names) if names else [f"projector {k + 1}" for k in range(len(outputs))]
        self.health_checks, self.max_grabs = health_checks, max_grabs
        self._mask = None if object_mask is None else np.asarray(object_mask, bool)
        self._details = list(projector_details or [])
        self.solos = [SoloOutput(self.outputs, k) for k in range(len(self.outputs))]
        shared = _SharedCamera(camera)
        self.rigs = [RigDevice(solo, shared, name=f"{name}: {self.names[k]}", clock=clock, frame_code=frame_code,
                               health_checks=health_checks, max_grabs=max_grabs)
                     for k, solo in enumerate(self.solos)]
        self.calibrated = False
        self.number = 0  # the joint shots' shared sequence number
        self.joint_stats = Counter()
        self.joint_settle_s = 0.0
        self.joint_bands: list = []
        self.joint_shows = 0  # times every output was given a frame of a joint set (the rest: one lit alone)

    # --- the MultiProjectorDevice interface
    def describe(self) -> MultiDeviceInfo:
        projectors = []
        for k, rig in enumerate(self.rigs):
            info = rig.describe()
            record = {**(self._details[k] if k < len(self._details) else {}), "name": self.names[k],
                      "output": info.details["projector"], "sync": info.details["sync"]}
            if "health" in info.details:
                record["health"] = info.details["health"]
            projectors.append(record)
        joint = {"shots": int(self.joint_stats["shots"]),
                 "rejected": {k: v for k, v in self.joint_stats.items() if k != "shots"},
                 "settle_s": round(self.joint_settle_s, 4)}
        return MultiDeviceInfo(self.name, tuple(tuple(o.size) for o in self.outputs), tuple(self.camera.size),
                               {"projectors": projectors, "camera": self.camera.describe(), "joint_sync": joint,
                                "device_timing": {"latency_s": max((r.latency.get("latency_s", 0.0)
                                                                    for r in self.rigs), default=0.0)}})

    def lock_exposure(self, white_frames=None) -> None:
        """Calibrate each projector alone (latency, its code's cells, its health checks), in turn."""
        if self.calibrated:
            return
        for k in range(len(self.rigs)):
            self.calibrate(k)
        self.joint_settle_s = max(r.sync.settle_s for r in self.rigs)
        self.joint_bands = [self._joint_band(k) for k in range(len(self.rigs))]
        self.calibrated = True

    def calibrate(self, k: int) -> None:
        """Projector k alone (the others black): its latency, its code's cells and its health checks; an error
        names the projector."""
        self._solo(k)
        try:
            self.rigs[k].lock_exposure(None)
        except (RigError, CaptureError) as exc:
            raise type(exc)(f"{self.label(k)}: {exc}") from None

    def label(self, k: int) -> str:
        return f"projector '{self.names[k]}'" if self._named else f"projector {k + 1}"

    def _joint_band(self, k: int):
        """(band, CellMap of that band alone) projector k's joint shots are verified by, or None: timing only.
        Neighbours alternate bands (k even: the top one, odd: the bottom), the other band black: two projectors
        side by side have their top bands at about one height, and one's code must not light the other's cells."""
        sync = self.rigs[k].sync
        if sync is None or not sync.verifies:
            return None
        bands = sync.cells.readable_bands()
        band = k % 2 if k % 2 in bands else bands[0]
        keys = [key for key in sync.cells.masks if key[0] == band]
        return band, fc.CellMap({key: sync.cells.masks[key] for key in keys},
                                {key: sync.cells.contrast[key] for key in keys})

    def reserved_rows(self, k: int) -> tuple[int, int]:
        """(top, bottom) rows of projector k's frame its code takes (the capture marks them invalid)."""
        return self.rigs[k].reserved_rows()

    def code_pixels(self):
        """(H,W) bool: camera pixels near any projector's code cells (None: no code read). The joint frames carry
        every projector's code, which a projector's alone captures do not: no registration uses these pixels."""
        masks = [rig._code_pixels(rig.sync.cells) for rig in self.rigs if rig.sync is not None and rig.sync.verifies]
        masks = [m for m in masks if m is not None]
        return np.any(np.stack(masks), axis=0) if masks else None

    def object_mask(self):
        return None if self._mask is None else self._mask.copy()

    def vary_noise(self, draw: int) -> None:
        vary = getattr(self.camera, "vary_noise", None)
        if vary is not None:
            vary(draw)

    def capture(self, frame_sets) -> list[np.ndarray]:
        if not self.calibrated:
            self.lock_exposure(None)
        out = []
        for frames in frame_sets:
            frames = list(frames)
            if len(frames) != len(self.outputs):
                raise RigError(f"one frame per projector: {len(self.outputs)}, got {len(frames)}")
            lit = [k for k, f in enumerate(frames) if f is not None]
            if len(lit) == 1:  # one projector alone: its own verified sync, the others black
                k = lit[0]
                self._solo(k)
                try:
                    out.append(self.rigs[k].capture([frames[k]])[0])
                except RigError as exc:
                    raise RigError(f"{self.label(k)}: {exc}") from None
            else:
                out.append(self._joint(frames))
        return out

    def close(self) -> None:
        errors = []
        for closer in [self.camera.close] + [o.close for o in self.outputs]:
            try:
                closer()
            except Exception as exc:  # close every one; say the first problem
                errors.append(exc)
        if errors:
            raise errors[0]

    # --- shots
    def _solo(self, k: int) -> None:
        for j, solo in enumerate(self.solos):
            if j != k:
                solo.release()

    def _joint(self, frames) -> np.ndarray:
        """Every output shows its frame (None: black) at once, stamped with one shared number; a grab is kept
        when every projector whose code the camera reads reads that number."""
        for solo in self.solos:
            solo.release()
        self.number += 1
        shown_frames = []
        for k, (rig, frame) in enumerate(zip(self.rigs, frames)):
            frame = _black(self.outputs[k].size) if frame is None else to_uint8(frame)
            if self.joint_bands[k] is not None:
                frame = fc.stamp(frame, rig.layout, self.number)
                other = 1 - self.joint_bands[k][0]
                top, bottom = rig.layout.reserved_rows()
                frame[slice(0, top) if other == 0 else slice(frame.shape[0] - bottom, None)] = 0
            shown_frames.append(frame)
        shown = self._show_all(shown_frames)
        self.joint_stats["shots"] += 1
        failures = []
        for attempt in range(self.max_grabs):
            self.clock.sleep_until(shown + self.joint_settle_s)
            self.camera.flush()
            image, _ = self.camera.grab()
            verdicts = [fc.read_code(image, band[1]).verdict(self.number) for band in self.joint_bands
                        if band is not None]
            bad = [v for v in verdicts if v != "ok"]
            if not bad:
                return image
            failures += bad
            for v in bad:
                self.joint_stats[v] += 1
            if "stale" in bad:
                self.joint_settle_s = min(self.joint_settle_s * 1.25 + 0.005, 2.0)
            if attempt % 3 == 2:
                shown = self._show_all(shown_frames)
        said = ", ".join(f"{n} {v}" for v, n in Counter(failures).items())
        raise RigError(f"the camera gave no good picture of the projectors together in {self.max_grabs} tries "
                       f"({said}): check that nothing covers the projections' top and bottom edges, that the "
                       f"camera's exposure is locked, and its cable")

    def _show_all(self, frames) -> float:
        """Show each output's frame; the moment the last one went up (the picture needs all of them)."""
        moment = 0.0
        self.joint_shows += 1
        for k, (output, frame) in enumerate(zip(self.outputs, frames)):
            try:
                moment = max(moment, output.show(frame))
            except RigError as exc:
                raise RigError(f"{self.label(k)}: {exc}") from None
        return moment


# ------------------------------------------------------------------ the simulated rig of several
class SimulatedScreens:
    """K SimulatedScreens seen by one camera: the camera's 'screen', whose timeline is the tuple of every
    screen's frame at each change (None where a screen has shown nothing yet: black)."""

    def __init__(self, screens: Sequence[SimulatedScreen]):
        self.screens = list(screens)
        self.size = tuple(self.screens[0].size)
        self.timeline: list[tuple[float, tuple]] = []
        self._current = [None] * len(self.screens)
        for k, screen in enumerate(self.screens):
            screen.on_show = self._shown(k)

    def _shown(self, k: int):
        def record(moment: float, frame) -> None:
            self._current[k] = frame
            self.timeline.append((moment, tuple(self._current)))
        return record

    def shown_at(self, moment: float):
        return SimulatedScreen.shown_at(self, moment)

    def same_frame(self, a, b: int) -> bool:
        if a is None:
            return False
        return all((x is None and y is None) or (x is not None and y is not None and np.array_equal(x, y))
                   for x, y in zip(self.timeline[a][1], self.timeline[b][1]))


class _SummedOptics:
    """A MultiProjectorDevice as the single optics a SimulatedCamera renders through: a 'frame' is the tuple of
    every screen's frame."""

    def __init__(self, optics: MultiProjectorDevice, sizes):
        self.optics, self.sizes = optics, [tuple(s) for s in sizes]
        self._info = optics.describe()

    def describe(self):
        return self._info

    def capture(self, frames):
        return self.optics.capture([list(f) for f in frames])

    def lock_exposure(self, _white) -> None:
        self.optics.lock_exposure([np.full((h, w, 3), 255, np.uint8) for w, h in self.sizes])
        self._info = self.optics.describe()

    def vary_noise(self, draw: int) -> None:
        self.optics.vary_noise(draw)


def simulated_multi_rig(optics: MultiProjectorDevice, faults: CameraFaults | None = None, clock=None,
                        names: Sequence[str] | None = None, fps: float = 30.0, buffer_frames: int = 4,
                        closes_after: Sequence[int | None] | None = None, seed: int = 0, **rig_options):
    """(MultiRigDevice, SimulatedScreens, SimulatedCamera): a real rig of K windows and one camera around
    ``optics``; closes_after[k]: projector k's display goes after that many frames (None: never)."""
    from .clock import VirtualClock

    clock = clock or VirtualClock()
    info = optics.describe()
    gone = list(closes_after or [None] * len(info.projector_sizes))
    screens = [SimulatedScreen(size, clock, gone[k] if k < len(gone) else None)
               for k, size in enumerate(info.projector_sizes)]
    for screen in screens:  # a display unplugged: its window's helper loses it
        screen.closed_message = "its display is gone (unplugged or switched off): connect it and capture again"
    together = SimulatedScreens(screens)
    camera = SimulatedCamera(together, _SummedOptics(optics, info.projector_sizes), faults, fps, buffer_frames,
                             clock, seed)
    details = [dict(p) for p in info.details.get("projectors", [])] if isinstance(info.details, dict) else []
    device = MultiRigDevice(screens, camera, names=names, name="simulated rig", clock=clock,
                            object_mask=optics.object_mask(), projector_details=details, **rig_options)
    return device, together, camera
