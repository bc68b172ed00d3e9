"""The displays and the cameras of this computer, for the panel's dropdowns.

Found on request (the Find Displays and Cameras button, a worker job: listing the displays starts the
projector window's helper, probing camera indices takes a moment each) and kept in this module for the
session, never in the .blend: another computer has other devices. A list that cannot be made (no screen,
no SDL2, no OpenCV) says why, and the other one is still found.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...lapig_core.rig import RigError
from ..services.errors import one_line
from ..services.jobs import WorkerJob

MAX_CAMERA_INDEX = 8


@dataclass(frozen=True)
class FoundDevices:
    displays: tuple = ()  # lapig_core.rig.projector_window.list_displays() entries
    cameras: tuple = ()  # lapig_core.rig.cameras.list_cameras() entries
    problems: tuple = ()  # why a list could not be made

    def display_items(self) -> list:
        """(index, label, description) for an EnumProperty."""
        return [(str(d["index"]), f"{d['index']}: {d['name']} ({d['width']}x{d['height']})",
                 f"Display {d['index']} '{d['name']}', {d['width']}x{d['height']} at ({d['x']}, {d['y']})")
                for d in self.displays]

    def camera_items(self) -> list:
        return [(str(c["index"]), f"{c['index']}: {c['backend']} ({c['width']}x{c['height']})",
                 f"Camera {c['index']} through {c['backend']}, {c['width']}x{c['height']}")
                for c in self.cameras]

    def display(self, wanted: str) -> tuple[dict | None, str]:
        """The found display ``wanted`` names (an index or a part of its name) and '', or None and why not."""
        from ...lapig_core.rig.window_process import DisplayChoiceError, choose_display

        try:
            return choose_display(list(self.displays), wanted), ""
        except DisplayChoiceError as exc:
            return None, str(exc)

    def summary(self) -> str:
        def count(n, word):
            return f"{n} {word}{'' if n == 1 else 's'}"

        return f"Found {count(len(self.displays), 'display')} and {count(len(self.cameras), 'camera')}"


_FOUND: dict = {"devices": None}


def found() -> FoundDevices | None:
    """What the last search found (None: no search yet in this session)."""
    return _FOUND["devices"]


def _list_displays() -> list:
    from ...lapig_core.rig.projector_window import list_displays

    return list_displays()


def _list_cameras(max_index: int) -> list:
    from ...lapig_core.rig.cameras import list_cameras

    return list_cameras(max_index)


def find_devices(report=lambda progress, message: None, max_cameras: int = MAX_CAMERA_INDEX) -> FoundDevices:
    """List both (each failure is a sentence in ``problems``), remember and return them."""
    displays, cameras, problems = [], [], []
    report(0.05, "listing the displays")
    try:
        displays = _list_displays()
    except (RigError, OSError, ImportError) as exc:
        problems.append(one_line(exc))
    report(0.5, "trying the camera indices")
    try:
        cameras = _list_cameras(max_cameras)
    except (RigError, OSError, ImportError) as exc:
        problems.append(f"the cameras could not be listed: {one_line(exc)}")
    _FOUND["devices"] = FoundDevices(tuple(displays), tuple(cameras), tuple(problems))
    return _FOUND["devices"]


class FindDevicesJob(WorkerJob):
    """find_devices on a worker thread, so Blender stays responsive while the cameras are probed. The
    camera view stops first: the camera it holds would not open for the search."""

    title = "LAPIG device search"

    def prepare(self):
        from .camera_view import stop_view

        stop_view()

    def work(self, inputs, report, cancel_event):
        return find_devices(report)


def display_note(devices: FoundDevices | None, wanted: str, projector_size) -> list:
    """What the panel says of the chosen display, as (text, ok) lines: which display it is and whether its
    size is the scene's projector's (looks are shown 1:1, never scaled); nothing before a search."""
    if devices is None or not wanted.strip() or not devices.displays:
        return []
    display, why = devices.display(wanted)
    if display is None:
        return [(why, False)]
    w, h = display["width"], display["height"]
    lines = [(f"Display {display['index']} '{display['name']}': {w}x{h}", True)]
    if projector_size and tuple(projector_size) != (w, h):
        lines.append((f"The projector is {projector_size[0]}x{projector_size[1]}: set its resolution to {w}x{h}",
                      False))
    return lines
