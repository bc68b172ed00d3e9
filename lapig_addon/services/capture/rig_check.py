"""Check the real rig before the long capture.

The job opens the rig as a capture would (the device factory's capture_device, on the thread the factory
needs: a real rig's on a worker thread) and runs its calibration and health checks (RigDevice.lock_exposure:
the display-to-camera latency, the frame code's cells, the exposure, a gray ramp up and down and its gamma).
A rig of several projectors (the factory's multi_capture_device) is checked projector by projector, each
alone with the others black, through the one camera (lapig_core.rig.multi_rig.MultiRigDevice.calibrate): its
lines are named after their projector. It captures and records nothing: the result is a short line per check
for the panel and a sentence per problem, kept in this module for the rig it checked (a changed rig shows no old
result).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ....lapig_core.capture.settings import CaptureError, CaptureSettings
from ....lapig_core.rig import RigError
from ..errors import one_line
from ..jobs import Job
from ..ports import Seams
from ..ways import chosen_way


@dataclass(frozen=True)
class CheckLine:
    name: str  # 'Latency', 'Frame code', 'Exposure', 'Gray ramp', 'Gamma' (several projectors: '<name>: Latency')
    text: str
    ok: bool | None  # None: not measured (an earlier step failed)

    def label(self) -> str:
        return f"{self.name}: {self.text}"


@dataclass(frozen=True)
class RigCheck:
    rig_key: str  # the identity key of the rig checked
    lines: tuple = ()
    problems: tuple = ()  # sentences: what to change

    @property
    def ok(self) -> bool:
        return not self.problems


def check_lines(device) -> tuple:
    """What a calibrated (or part-calibrated) RigDevice measured, one line per check."""
    latency = getattr(device, "latency", {}) or {}
    health = getattr(device, "health", {}) or {}
    failed = set(health.get("failed", ()))
    lines = [CheckLine("Latency", f"{latency['latency_s'] * 1000:.0f} ms from display to camera", True)
             if "latency_s" in latency else CheckLine("Latency", "not measured", None)]
    code = getattr(device, "code_state", "not measured")
    lines.append(CheckLine("Frame code", code, None if code == "not measured" else
                           code.startswith(("verified, top and bottom", "off"))))
    exposure = health.get("exposure")
    if exposure is not None:
        lines.append(CheckLine("Exposure", f"white clips on {exposure['white_clipped_share']:.1%}, black reads 0 on "
                                           f"{exposure['black_crushed_share']:.1%} of the lit surface",
                               "exposure" not in failed))
    elif "lit_share_of_camera" in health:
        lines.append(CheckLine("Exposure", f"the projection lights {health['lit_share_of_camera']:.1%} of the "
                                           "camera's picture", False))
    else:
        lines.append(CheckLine("Exposure", "not checked", None))
    ramp = health.get("ramp")
    lines.append(CheckLine("Gray ramp", f"up and down differ by {ramp['passes_differ_by']:.1%}", "ramp" not in failed)
                 if ramp else CheckLine("Gray ramp", "not checked", None))
    gamma = health.get("ramp_gamma")
    lines.append(CheckLine("Gamma", f"{gamma:.2f} (projector and camera together)", True) if gamma is not None
                 else CheckLine("Gamma", "not measured", None))
    return tuple(lines)


_LAST: dict = {"check": None}


def last_check(rig_key: str) -> RigCheck | None:
    """The last check of the rig with this identity key (None: not checked in this session)."""
    check = _LAST["check"]
    return check if check is not None and check.rig_key == rig_key else None


class RigCheckJob(Job):
    title = "LAPIG rig check"

    def __init__(self, seams: Seams, settings: CaptureSettings):
        super().__init__()
        self.seams, self.settings = seams, settings

    def _check_joint(self):
        """Every projector of a rig of several checked alone (the others black), through the one camera: its
        lines, each named after its projector, and its problems, each a sentence naming it."""
        devices = self.seams.devices
        lines, problems = [], []
        yield 0.05, "opening every projector's window and the camera"
        try:
            if not devices.opens_several:
                raise CaptureError(f"{devices.rig_identity().name} cannot open several projectors at once")
            with devices.multi_capture_device(self.settings) as device:
                count = len(device.rigs)
                for k, rig in enumerate(device.rigs):
                    yield 0.1 + 0.85 * k / count, f"checking {device.label(k)}: latency, frame code, exposure, ramp"
                    try:
                        device.calibrate(k)
                    except CaptureError as exc:
                        problems.extend(f"{device.label(k)}: {p}" for p in
                                        (rig.health.get("problems") or [one_line(exc)]))
                    except RigError as exc:
                        problems.append(one_line(exc))
                    lines += [CheckLine(f"{device.names[k]}: {line.name}", line.text, line.ok)
                              for line in check_lines(rig)]
                yield 0.95, "closing the devices"
        except (CaptureError, RigError, OSError) as exc:
            problems.append(one_line(exc))
        return RigCheck(devices.rig_identity().key(), tuple(lines), tuple(problems))

    def _check(self):
        """The one place the check's way is chosen, by the rig's strategy: several projectors are checked one by
        one through the factory's multi_capture_device."""
        return (yield from chosen_way(self.seams.store.read().rig, self._check_one, self._check_joint)())

    def _check_one(self):
        devices = self.seams.devices
        device, problems = None, []
        yield 0.05, "opening the projector window and the camera"
        try:
            with devices.capture_device(self.settings) as device:
                yield 0.2, "measuring the latency, finding the frame code, checking the exposure and a gray ramp"
                w, h = device.describe().projector_size
                try:
                    device.lock_exposure(np.full((h, w, 3), 255, np.uint8))
                except CaptureError as exc:  # the health checks failed: each problem is a sentence of its own
                    problems.extend(getattr(device, "health", {}).get("problems") or [one_line(exc)])
                yield 0.95, "closing the devices"
        except (CaptureError, RigError, OSError) as exc:  # the rig did not open, or a step could not run
            problems.append(one_line(exc))
        return RigCheck(devices.rig_identity().key(), check_lines(device), tuple(problems))

    def steps(self):
        self.result = yield from self.drive(self._check, self.seams.devices.main_thread)
        _LAST["check"] = self.result
