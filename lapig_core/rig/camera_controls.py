# SPDX-License-Identifier: GPL-3.0-or-later
"""Locking a cv2.VideoCapture's automatic controls and reading every value back.

What a control takes, and in which units, is the backend's and the driver's business: a value is
set, read back, and recorded as asked and as read. Nothing here fails because a control did not
take; ``describe()["not_locked"]`` says which, and the rig's health checks decide what that means.

Units are the backend's own (OpenCV passes them through):
- exposure: V4L2 ``exposure_time_absolute`` in 100 us units (e.g. 100 = 10 ms); DirectShow log2 of
  seconds (e.g. -6 = 1/64 s); Media Foundation and AVFoundation expose little or nothing;
- gain, focus: the driver's range (``v4l2-ctl -L`` lists it on Linux);
- white_balance: a colour temperature in kelvin.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

import cv2

# CAP_PROP_AUTO_EXPOSURE values meaning "manual", in the order tried. V4L2: 0.25 where OpenCV maps
# the value onto the control's range (most UVC cameras, menu 0..3: 0.25 -> 1 = manual), 1 where it
# passes the raw menu value (1 = V4L2_EXPOSURE_MANUAL). DirectShow and the others: 0.25, then 0.
MANUAL_EXPOSURE = {cv2.CAP_V4L2: (0.25, 1.0)}
MANUAL_EXPOSURE_OTHER = (0.25, 0.0)


@dataclass(frozen=True)
class Control:
    name: str  # the key in describe()["settings"]
    prop: int  # the cv2.CAP_PROP_* it sets
    exact: bool = False  # a count (pixels, buffers): the read-back must equal what was asked


# Set in this order: the format first (a format change restarts the stream, which on some drivers
# resets the controls), each automatic control off before its manual value, the buffer last.
CONTROLS = (
    Control("width", cv2.CAP_PROP_FRAME_WIDTH, exact=True),
    Control("height", cv2.CAP_PROP_FRAME_HEIGHT, exact=True),
    Control("auto_exposure", cv2.CAP_PROP_AUTO_EXPOSURE),
    Control("exposure", cv2.CAP_PROP_EXPOSURE),
    Control("gain", cv2.CAP_PROP_GAIN),
    Control("autofocus", cv2.CAP_PROP_AUTOFOCUS),
    Control("focus", cv2.CAP_PROP_FOCUS),
    Control("auto_white_balance", cv2.CAP_PROP_AUTO_WB),
    Control("white_balance", cv2.CAP_PROP_WB_TEMPERATURE),
    Control("buffer_size", cv2.CAP_PROP_BUFFERSIZE, exact=True),
)
CONTROL_BY_NAME = {control.name: control for control in CONTROLS}
AUTOMATIC = ("auto_exposure", "autofocus", "auto_white_balance")  # turned off, always


def _read(cap, prop: int) -> float | None:
    try:
        return float(cap.get(prop))
    except cv2.error:
        return None


def _set(cap, prop: int, value: float) -> bool:
    try:
        return bool(cap.set(prop, float(value)))
    except cv2.error:
        return False


def matches(read_back: float | None, asked: float, exact: bool = False) -> bool:
    """Whether a read-back value is the one asked (1 % for continuous controls)."""
    if read_back is None:
        return False
    if exact:
        return round(read_back) == round(asked)
    return abs(read_back - asked) <= max(1e-6, 0.01 * abs(asked))


def _manual_values(api: int, name: str) -> tuple[float, ...]:
    if name == "auto_exposure":
        return MANUAL_EXPOSURE.get(api, MANUAL_EXPOSURE_OTHER)
    return (0.0,)  # CAP_PROP_AUTOFOCUS and CAP_PROP_AUTO_WB: 0 is off


def set_control(cap, api: int, name: str, asked) -> dict:
    """Set one control (an automatic one: to manual, trying each encoding) and read it back."""
    control = CONTROL_BY_NAME[name]
    entry = {"asked": asked, "before": _read(cap, control.prop)}
    if name in AUTOMATIC:
        tried = []
        for value in _manual_values(api, name):
            tried.append(value)
            accepted = _set(cap, control.prop, value)
            read_back = _read(cap, control.prop)
            entry.update(asked=value, accepted=accepted, read_back=read_back)
            if accepted and matches(read_back, value):
                break
        if len(tried) > 1:
            entry["tried"] = tried
    elif asked is not None:
        entry["accepted"] = _set(cap, control.prop, asked)
        entry["read_back"] = _read(cap, control.prop)
    else:
        entry["read_back"] = entry["before"]
    return entry


def lock_controls(cap, api: int, asked: dict) -> dict:
    """Every control of CONTROLS set in order (automatic ones off, the others where asked), then
    all read back once more, as they stand together: {name: {asked, before, accepted, read_back,
    took}}; took is None where nothing was asked."""
    settings = {control.name: set_control(cap, api, control.name, asked.get(control.name))
                for control in CONTROLS}
    return reread(cap, settings)


def reread(cap, settings: dict) -> dict:
    """Read every recorded control back and decide again whether it took."""
    for name, entry in settings.items():
        control = CONTROL_BY_NAME[name]
        entry["read_back"] = _read(cap, control.prop)
        if entry["asked"] is None:
            entry["took"] = None
        else:
            entry["took"] = bool(entry.get("accepted")) and matches(entry["read_back"], entry["asked"],
                                                                    control.exact)
    return settings


def not_locked(settings: dict) -> list[str]:
    """The controls asked for that did not take, in the order they were set."""
    return [name for name, entry in settings.items() if entry["asked"] is not None and not entry["took"]]


@contextlib.contextmanager
def quiet_opencv():
    """OpenCV's own warnings silenced (a probe of an empty index is not news); restored after."""
    get_level = getattr(cv2, "getLogLevel", None)
    set_level = getattr(cv2, "setLogLevel", None)
    if get_level is None or set_level is None:
        yield
        return
    previous = get_level()
    set_level(0)  # LOG_LEVEL_SILENT
    try:
        yield
    finally:
        set_level(previous)
