"""The device factory of a real rig: a projector window on a display and a camera (services/ports.DeviceFactory).

A RigSpec says which display and which camera; the panel's properties (scene.lapig.real, read by
blender/scene_state.real_rig_spec) and the headless commands' --rig options build it; its JSON is for data
files and tests. The rig's identity is the spec's name and devices, so staleness follows the rig, not
Blender objects: a capture made with another camera or on another display is not this rig's.

Its devices block (a camera's grab, the waits of the sync), so main_thread is False: the jobs drive them
on a worker thread and Blender stays responsive. Train's rendered choice and Render Real Capture use
the same rig: a real rig judges a projection by projecting it.

``SimulatedRigFactory`` wraps another factory's devices (the Cycles studio, or the numpy fake) in a real
rig's timing and faults (lapig_core.rig.simulated), so the whole real-device path runs without hardware.
"""
from __future__ import annotations

import contextlib
import json
from dataclasses import asdict, dataclass, field, fields

from ...lapig_core.capture.settings import CaptureError, CaptureSettings
from ...lapig_core.rig import RigError
from ..services.ports import RigIdentity

CAMERA_SETTINGS = ("width", "height", "exposure", "gain", "focus", "white_balance")


@dataclass(frozen=True)
class RigSpec:
    """A real rig, as the scene and the command line name it."""
    name: str = "real rig"
    display: str = "1"  # an index, or a part of the display's name
    camera: str = "0"  # an index, a URL or a video file; ignored with a tethered folder
    camera_backend: str = "auto"
    tethered_folder: str = ""  # a folder a tethering program saves each picture into
    camera_settings: dict = field(default_factory=dict)  # CAMERA_SETTINGS -> value; missing: the camera's own
    frame_code: bool = True
    health_checks: bool = True

    @classmethod
    def from_json(cls, text: str) -> "RigSpec":
        """The spec a scene recorded; ValueError with what is wrong (a data file never runs code)."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"the scene's real rig is not readable ({exc.msg}): set it up again") from None
        if not isinstance(data, dict):
            raise ValueError("the scene's real rig is not readable: set it up again")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"the scene's real rig has unknown settings {unknown}: set it up again")
        settings = data.get("camera_settings", {})
        if not isinstance(settings, dict) or set(settings) - set(CAMERA_SETTINGS):
            raise ValueError(f"the real rig's camera settings must be among {list(CAMERA_SETTINGS)}")
        return cls(**{**data, "display": str(data.get("display", "1")), "camera": str(data.get("camera", "0"))})

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    def problem(self, display: bool = True, camera: bool = True) -> str:
        """What the installer must still choose before the rig opens ('' when nothing); display=False or
        camera=False leaves that device out (the live window needs no camera, the camera view no display)."""
        if display and not self.display.strip():
            return ("Choose the projector's display: an index or a part of its name (Find Displays and "
                    "Cameras lists them)")
        if camera and not (self.tethered_folder.strip() or self.camera.strip()):
            return "Choose the camera: an index, a stream URL or a video file (or a tethered folder)"
        return ""

    def devices(self) -> dict:
        """What the rig's identity names: enough to tell another display or camera apart."""
        camera = (f"tethered folder {self.tethered_folder}" if self.tethered_folder
                  else f"camera {self.camera} ({self.camera_backend})")
        return {"projector": f"display {self.display}", "camera": camera}


class RealRigFactory:
    main_thread = False
    opens_several = True  # a window per display and the one camera (multi_capture_device)

    def __init__(self, spec: RigSpec, window_factory=None, camera_factory=None, expected_size=None, clock=None,
                 projectors=()):
        """window_factory(display) and camera_factory(spec): the real ones by default (tests pass others);
        expected_size: the projector resolution the looks are made for (the display must have it);
        clock: the devices' (lapig_core.rig.clock; None: the real one); projectors: a rig of several, each
        projector's (name, display, (width, height)), projector 1 first (its display is the spec's); () for one
        projector, whose identity stays the spec's devices (the key its captures were recorded under)."""
        self.spec, self.expected_size = spec, tuple(expected_size) if expected_size else None
        self.projectors = tuple((str(n), str(d), tuple(size) if size else None) for n, d, size in projectors)
        self.clock = clock if clock is not None else _clock()
        self._window = window_factory or _projector_window
        self._camera = camera_factory or _camera

    def rig_identity(self) -> RigIdentity:
        devices = self.spec.devices()
        if self.projectors:  # a rig of several: every projector's display is the rig's (one: the spec's display)
            devices["projectors"] = [f"{name} on display {display}" for name, display, _ in self.projectors]
        return RigIdentity(self.spec.name, devices)

    @contextlib.contextmanager
    def _rig(self, calibrated: bool = False):
        """calibrated: measure the latency and find the frame code before handing it over (a projection
        of compensated images is verified like a capture; its health was checked by the capture)."""
        from ...lapig_core.rig.rig_device import RigDevice

        problem = self.spec.problem()
        if problem:
            raise CaptureError(problem)
        release_devices()
        window = self._window(self.spec.display)
        try:
            problem = display_size_problem("the projector's display", "the scene's projector", window.size,
                                           self.expected_size)
            if problem:
                raise CaptureError(problem)
            camera = self._camera(self.spec)
        except BaseException:
            window.close()
            raise
        device = RigDevice(window, camera, name=self.spec.name, frame_code=self.spec.frame_code,
                           health_checks=self.spec.health_checks and not calibrated,
                           **({"clock": self.clock} if self.clock is not None else {}))
        self.last_device = device
        with device:
            if calibrated:
                device.lock_exposure(None)
            yield device

    def capture_device(self, settings: CaptureSettings):
        return self._rig()

    @contextlib.contextmanager
    def multi_capture_device(self, settings: CaptureSettings):
        """A rig of several projectors: one window per display, each its own helper process, and the one
        camera (lapig_core.rig.multi_rig.MultiRigDevice: each projector calibrated and shot alone, the joint
        frames on every window at once)."""
        from ...lapig_core.rig.multi_rig import MultiRigDevice

        problem = self.spec.problem() or multi_display_problem(self.projectors)
        if problem:
            raise CaptureError(problem)
        from .live_output import open_each

        release_devices()
        windows = open_each([d for _, d, _ in self.projectors], self._window)  # every helper starts at once
        try:
            for (name, display, size), window in zip(self.projectors, windows):
                problem = display_size_problem(f"projector '{name}''s display '{display}'", "the projector",
                                               window.size, size)
                if problem:
                    raise CaptureError(problem)
            camera = self._camera(self.spec)
        except BaseException:
            for window in windows:
                window.close()
            raise
        device = MultiRigDevice(windows, camera, names=[n for n, _, _ in self.projectors], name=self.spec.name,
                                frame_code=self.spec.frame_code, health_checks=self.spec.health_checks,
                                **({"clock": self.clock} if self.clock is not None else {}))
        self.last_device = device
        with device:
            yield device

    def setup_device(self, setup_meta: dict, seed: int = 0):
        if setup_meta.get("fingerprint") not in (None, self.rig_identity().key()):
            raise CaptureError("this capture was made with another rig: connect that one, or capture again")
        return self._rig(calibrated=True)


class SimulatedRigFactory:
    """Another factory's devices as the optics of a simulated real rig (latency, faults, a frame code)."""

    def __init__(self, optics_factory, faults=None, name: str = "simulated rig", clock=None, names=None,
                 closes_after=None, **rig_options):
        """names: a rig of several projectors' names; closes_after[k]: projector k's display goes after that
        many frames (None: never), as an unplugged display does."""
        self.optics_factory, self.faults, self.name = optics_factory, faults, name
        self.names, self.closes_after = names, closes_after
        self.clock, self.rig_options = clock, rig_options
        self.main_thread = optics_factory.main_thread  # Cycles renders the optics: its thread rules
        self.opens_several = optics_factory.opens_several  # several simulated windows over optics of several
        self.last = None  # (device, screen, camera) of the last rig opened: the bench reads the truth there

    def rig_identity(self) -> RigIdentity:
        inner = self.optics_factory.rig_identity()
        return RigIdentity(self.name, {"optics": inner.name, **inner.devices}, inner.fingerprint)

    @contextlib.contextmanager
    def _rig(self, optics_cm, calibrated: bool = False):
        from ...lapig_core.rig.simulated import simulated_rig

        with optics_cm as optics:
            options = {**self.rig_options, **({"health_checks": False} if calibrated else {})}
            device, screen, camera = simulated_rig(optics, self.faults, clock=self.clock, **options)
            self.last = (device, screen, camera)
            if calibrated:
                device.lock_exposure(None)
            yield device

    def capture_device(self, settings: CaptureSettings):
        return self._rig(self.optics_factory.capture_device(settings))

    @contextlib.contextmanager
    def multi_capture_device(self, settings: CaptureSettings):
        """K simulated windows and one simulated camera around the optics factory's device of several (the
        Cycles studio of every projector): lapig_core.rig.multi_rig.simulated_multi_rig."""
        from ...lapig_core.rig.multi_rig import simulated_multi_rig

        if not self.opens_several:
            raise CaptureError(f"{self.name} cannot simulate several projectors over these optics")
        with self.optics_factory.multi_capture_device(settings) as optics:
            options = dict(self.rig_options)
            options.pop("geometry", None)
            device, screens, camera = simulated_multi_rig(optics, self.faults, clock=self.clock, names=self.names,
                                                          closes_after=self.closes_after, **options)
            self.last = (device, screens, camera)
            yield device

    def setup_device(self, setup_meta: dict, seed: int = 0):
        from ...lapig_core.rig.simulated import optics_meta

        return self._rig(self.optics_factory.setup_device(optics_meta(setup_meta), seed), calibrated=True)


def display_size_problem(display: str, projector: str, display_size, expected) -> str:
    """Why a projector's window cannot show the looks ('' when it can): its display is not the resolution the
    looks are made for. One rule and one wording for a rig of one projector and of several."""
    if not expected or tuple(display_size) == tuple(expected):
        return ""
    w, h = display_size
    return (f"{display} is {w}x{h} but {projector} is {expected[0]}x{expected[1]}: set {projector}'s resolution "
            f"to {w}x{h}, its native one, and capture again")


def multi_display_problem(projectors) -> str:
    """Why a rig of several projectors cannot open its windows ('' when it can): each needs its own display."""
    seen = {}
    for name, display, _ in projectors:
        key = display.strip()
        if not key:
            return f"Choose projector '{name}''s display: each projector of a real rig has its own"
        if key in seen:
            return f"Projectors '{seen[key]}' and '{name}' are both on display '{key}': give each its own display"
        seen[key] = name
    return ""


def release_devices() -> None:
    """The live projector window and the camera view let go of the display and the camera, which the rig
    is about to open (a camera serves one program at a time; two full-screen windows fight)."""
    from .camera_view import stop_view
    from .live_output import close_live

    close_live()
    stop_view()


def _clock():
    """The devices' clock where the factory is given none: None, the real one (tests that simulate the
    hardware return their VirtualClock, shared with the simulated window and camera)."""
    return None


def _projector_window(display: str):
    from ...lapig_core.rig.projector_window import ProjectorWindow

    return ProjectorWindow(int(display) if display.strip().isdigit() else display)


def _camera(spec: RigSpec):
    if spec.tethered_folder:
        from ...lapig_core.rig.tethered import TetheredFolderCamera

        return TetheredFolderCamera(spec.tethered_folder)
    from ...lapig_core.rig.cameras import OpenCVCamera

    try:
        return OpenCVCamera(spec.camera, backend=spec.camera_backend, **spec.camera_settings)
    except TypeError as exc:  # a setting this camera class does not take
        raise RigError(f"the camera settings {spec.camera_settings} are not understood ({exc})") from None
