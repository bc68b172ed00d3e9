# SPDX-License-Identifier: GPL-3.0-or-later
"""A simulated projector and camera with a real rig's faults, for the tests and ``bench hardware``.

The optics (what the camera sees of a projected frame) come from any CaptureDevice: the numpy fake of
the tests, or the Cycles studio. Around them, the timing of real hardware:

- the screen shows a frame when asked and remembers when (SimulatedScreen, a ProjectorOutput);
- the camera (SimulatedCamera, a Camera) produces a frame every 1/fps seconds, of what the screen showed
  ``latency_s`` (plus jitter) earlier; its driver queues up to ``buffer_frames`` frames and drops newer
  ones while the queue is full (as V4L2 does when nobody reads), so a grab after a pause returns an old
  frame unless the rig flushes;
- faults on request: dropped (black) frames, repeated frames, torn frames (the top of the newest picture,
  the bottom of the one before), a slow start (black for a while after opening), an auto exposure that
  meters each frame and drifts (unless locked, where the camera allows it), sensor noise, a camera that
  is unplugged after N grabs, and a window the user closes after N frames.

Every returned image is logged with what it truly shows (``SimulatedCamera.log``), so a benchmark can
count how many bad frames the sync caught.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass

import numpy as np

from ..capture.device import CaptureDevice
from . import RigError
from .clock import REAL_CLOCK


@dataclass
class CameraFaults:
    drop_rate: float = 0.0  # share of frames that come back black
    repeat_rate: float = 0.0  # share of frames that repeat the previous one
    torn_rate: float = 0.0  # share of frames torn between two shown frames
    latency_s: float = 0.0  # display to capture
    jitter_s: float = 0.0  # uniform extra latency, 0..jitter_s
    slow_start_s: float = 0.0  # black frames for this long after opening
    auto_exposure: bool = False  # meters every frame, towards a mean of ae_target
    exposure_lockable: bool = True  # locking turns the auto exposure off
    ae_target: float = 0.45
    ae_rate: float = 0.06  # share of the metering error (in log) corrected per frame: about 1 s to settle
    noise: float = 0.0  # sensor noise (levels 0..1, standard deviation), on top of the optics' own
    unplug_after: int | None = None  # grabs before the camera stops answering


class SimulatedScreen:
    """A ProjectorOutput: shows frames instantly and keeps the timeline of what was on screen."""

    def __init__(self, size, clock=REAL_CLOCK, closes_after: int | None = None, frame_bit_depths=(8,)):
        self.size = tuple(size)
        self.clock = clock
        self.timeline: list[tuple[float, np.ndarray]] = []  # (shown at, frame)
        self.closes_after = closes_after
        self.closed_message = "the projector window was closed (Esc or the window's close button)"
        self.frame_bit_depths = frame_bit_depths
        self.on_show = None  # on_show(moment, frame): a rig of several screens keeps their joint timeline

    def show(self, frame) -> float:
        w, h = self.size
        if frame.shape[:2] != (h, w):
            raise RigError(f"a {frame.shape[1]}x{frame.shape[0]} frame does not fit the {w}x{h} display")
        if self.closes_after is not None and len(self.timeline) >= self.closes_after:
            raise RigError(self.closed_message)
        t = self.clock.now()
        self.timeline.append((t, np.array(frame, copy=True)))
        if self.on_show is not None:
            self.on_show(t, self.timeline[-1][1])
        return t

    def shown_at(self, moment: float) -> int | None:
        """Index into the timeline of the frame on screen at ``moment`` (None: nothing yet)."""
        index = None
        for i, (t, _) in enumerate(self.timeline):
            if t <= moment:
                index = i
            else:
                break
        return index

    def same_frame(self, a: int | None, b: int) -> bool:
        """Whether timeline entries a and b show the same pixels (a frame shown again is the same frame)."""
        return a is not None and np.array_equal(self.timeline[a][1], self.timeline[b][1])

    def describe(self) -> dict:
        return {"kind": "simulated screen", "width": self.size[0], "height": self.size[1]}

    def close(self) -> None:
        pass


class SimulatedCamera:
    """A Camera over ``optics`` (a CaptureDevice whose capture([frame]) is the camera's view of it)."""

    def __init__(self, screen: SimulatedScreen, optics: CaptureDevice, faults: CameraFaults | None = None,
                 fps: float = 30.0, buffer_frames: int = 4, clock=REAL_CLOCK, seed: int = 0):
        self.screen, self.optics, self.faults = screen, optics, faults or CameraFaults()
        self.fps, self.buffer_frames, self.clock = fps, buffer_frames, clock
        self.rng = np.random.default_rng(seed)
        self.size = optics.describe().camera_size
        self.opened_at = clock.now()
        self.produced = 0  # frames the sensor made since opening
        self.queue: collections.deque = collections.deque()
        self.gain = 1.0
        self.exposure_locked = False
        self.grabs = 0
        self.log: list[dict] = []  # per returned image: what it truly shows
        self._renders: dict[int, np.ndarray] = {}  # timeline index -> the optics' float image
        self._last: tuple[np.ndarray, dict] | None = None

    # --- the Camera interface
    def grab(self):
        self.grabs += 1
        if self.faults.unplug_after is not None and self.grabs > self.faults.unplug_after:
            raise RigError("the camera stopped answering (unplugged?): check its cable and capture again")
        self._produce()
        while not self.queue:
            next_at = self.opened_at + (self.produced + 1) / self.fps
            self.clock.sleep_until(next_at)
            self._produce()
        image, truth = self.queue.popleft()
        self.log.append({**truth, "on_screen": len(self.screen.timeline) - 1})
        return image, self.clock.now()

    def flush(self) -> None:
        self._produce()
        self.queue.clear()

    def lock(self) -> bool:
        """Turn the auto exposure off; False where this camera does not let it. The optics set their exposure
        for the projector's white, as the virtual camera they simulate would (the Cycles studio's auto
        exposure)."""
        w, h = self.screen.size
        self.optics.lock_exposure(np.full((h, w, 3), 255, np.uint8))
        self._renders.clear()
        if self.faults.exposure_lockable:
            self.exposure_locked = True
        return self.exposure_locked or not self.faults.auto_exposure

    def describe(self) -> dict:
        auto = self.faults.auto_exposure and not self.exposure_locked
        # "optics": what the simulated optics record of themselves, so the setup can be reopened on them
        # (Train's rendered choice, Refine): the Cycles studio needs its camera's response and size
        return {"kind": "simulated camera", "fps": self.fps, "width": self.size[0], "height": self.size[1],
                "settings": {"auto_exposure": {"asked": False, "read_back": auto, "took": not auto}},
                "not_locked": ["auto_exposure"] if auto else [], "optics": self.optics.describe().details}

    def close(self) -> None:
        pass

    def vary_noise(self, draw: int) -> None:
        """The optics' next renders are a new noise draw (Cycles' seed); frames rendered already stay."""
        self.optics.vary_noise(draw)

    # --- the sensor
    def _produce(self) -> None:
        """Make the frames whose time has come; the driver keeps the oldest buffer_frames."""
        due = int(np.floor((self.clock.now() - self.opened_at) * self.fps + 1e-6))  # + 1e-6: float round-off
        while self.produced < due:
            self.produced += 1
            frame = self._expose(self.opened_at + self.produced / self.fps)
            if len(self.queue) < self.buffer_frames:
                self.queue.append(frame)

    def _expose(self, moment: float):
        f = self.faults
        if moment - self.opened_at < f.slow_start_s:
            return self._black({"shows": None, "fault": "slow start"})
        seen_at = moment - f.latency_s - (self.rng.uniform(0, f.jitter_s) if f.jitter_s else 0.0)
        index = self.screen.shown_at(seen_at)
        if index is None:
            return self._black({"shows": None, "fault": "nothing shown yet"})
        roll = self.rng.random()
        if roll < f.drop_rate:
            return self._black({"shows": None, "fault": "dropped"})
        roll -= f.drop_rate
        if roll < f.repeat_rate and self._last is not None:
            image, truth = self._last
            return image, {**truth, "fault": "repeated"}
        roll -= f.repeat_rate
        picture = self._render(index)
        truth = {"shows": index, "fault": None}
        if roll < f.torn_rate and index > 0:
            before = self._render(index - 1)
            rows = picture.shape[0] // 2
            picture = np.concatenate([picture[:rows], before[rows:]])
            truth = {"shows": None, "fault": "torn"}
        image = self._sensor(picture)
        self._last = (image, truth)
        return image, truth

    def _render(self, index: int) -> np.ndarray:
        if index not in self._renders:
            image = self.optics.capture([self.screen.timeline[index][1]])[0]
            self._renders[index] = np.asarray(image, np.float32) / (255.0 if image.dtype == np.uint8 else 1.0)
            if len(self._renders) > 8:  # only recent frames are ever seen again
                self._renders.pop(min(self._renders))
        return self._renders[index]

    def _sensor(self, picture: np.ndarray) -> np.ndarray:
        f = self.faults
        x = picture * self.gain
        if f.noise:
            x = x + f.noise * self.rng.standard_normal(x.shape, dtype=np.float32)
        image = np.round(np.clip(x, 0, 1) * 255).astype(np.uint8)
        if f.auto_exposure and not self.exposure_locked:  # meters this frame for the next one
            mean = max(float(picture.mean()) * self.gain, 1e-3)
            self.gain = float(np.clip(self.gain * (f.ae_target / mean) ** f.ae_rate, 0.25, 4.0))
        return image

    def _black(self, truth: dict):
        w, h = self.size
        image = np.zeros((h, w, 3), np.uint8)
        if self.faults.noise:
            image = np.round(np.clip(self.faults.noise * self.rng.standard_normal((h, w, 3)), 0, 1)
                             * 255).astype(np.uint8)
        return image, truth


def simulated_rig(optics: CaptureDevice, faults: CameraFaults | None = None, clock=None, fps: float = 30.0,
                  buffer_frames: int = 4, closes_after: int | None = None, seed: int = 0, **rig_options):
    """(RigDevice, screen, camera): a real rig's device over simulated hardware around ``optics``."""
    from .clock import VirtualClock
    from .rig_device import RigDevice

    clock = clock or VirtualClock()
    screen = SimulatedScreen(optics.describe().projector_size, clock, closes_after)
    camera = SimulatedCamera(screen, optics, faults, fps, buffer_frames, clock, seed)
    rig_options.setdefault("geometry", optics.geometry_checks())  # the optics' truth (Cycles knows it)
    return RigDevice(screen, camera, name="simulated rig", clock=clock, **rig_options), screen, camera


def optics_meta(setup_meta: dict) -> dict:
    """A simulated rig's setup.json as its optics recorded it (the simulated camera keeps their record
    under camera.optics), so they can reopen it; any other setup as it is."""
    camera = setup_meta.get("camera")
    optics = camera.get("optics") if isinstance(camera, dict) else None
    return {**setup_meta, **optics} if isinstance(optics, dict) else setup_meta


def sync_outcome(device, screen: SimulatedScreen, camera: SimulatedCamera) -> dict:
    """How the rig's verification did against the truth: of the grabs it verified, the bad ones (not a
    clean picture of the frame on screen) and how many it caught; the good ones it threw away."""
    verdicts = device.sync.verdicts if device.sync is not None else []
    verified = camera.log[len(camera.log) - len(verdicts):] if verdicts else []
    bad = [not screen.same_frame(t["shows"], t["on_screen"]) or t["fault"] == "torn" for t in verified]
    caught = [v != "ok" for v in verdicts]
    faults = collections.Counter(t["fault"] or "late" for t, b in zip(verified, bad) if b)
    missed = collections.Counter(t["fault"] or "late" for t, b, c in zip(verified, bad, caught) if b and not c)
    return {"verified_grabs": len(verdicts), "bad": sum(bad), "caught": sum(b and c for b, c in zip(bad, caught)),
            "false_alarms": sum(c and not b for b, c in zip(bad, caught)),
            "bad_by_fault": dict(faults), "missed_by_fault": dict(missed)}
