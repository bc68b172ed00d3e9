"""What each panel step shows: done, stale (the scene changed) or missing, and what blocks it."""
from __future__ import annotations

import os

from ...lapig_core.common.deps import missing_required
from ..blender import storage
from ..blender.fingerprint import rig_fingerprint


def _rig_now(s) -> str | None:
    if s.projector is None or s.camera is None or s.target is None:
        return None
    return rig_fingerprint(s.projector, s.camera, s.target)


def capture_blocker(scene) -> str:
    s = scene.lapig
    if s.projector is None or s.camera is None or s.target is None:
        return "Add the projector and camera first"
    return ""


def capture_status(scene) -> tuple[str, str]:
    """('MISSING'|'STALE'|'DONE', the capture folder): the one check behind the panel, the Capture
    step's state and the jobs that need a capture."""
    s = scene.lapig
    folder = storage.resolve_capture_dir(s.last_capture_dir)
    if not folder:
        return "MISSING", ""
    now = _rig_now(s)
    if s.last_capture_fingerprint and now is not None and now != s.last_capture_fingerprint:
        return "STALE", folder
    return "DONE", folder


def _capture_ok(scene) -> str:
    blocker = capture_blocker(scene)
    if blocker:
        return blocker
    state, _ = capture_status(scene)
    if state == "MISSING":
        return "Capture the surface first"
    if state == "STALE":
        return "The rig or the object moved: capture again"
    return ""


def models_blocker(scene) -> str:
    missing = [d.package for d in missing_required() if d.package in ("torch",)]
    if missing:
        return "Install torch (see the add-on preferences)"
    return _capture_ok(scene)


def models_state(scene) -> tuple[str, str]:
    s = scene.lapig
    if not s.models_fingerprint:
        return "MISSING", "Not trained for this capture (Generate trains them too)"
    if s.models_fingerprint != s.last_capture_fingerprint:
        return "STALE", "Trained for an older capture"
    return "DONE", s.models_status or "Fine-tuned for this capture"


_AVAILABILITY: dict = {}  # backend -> (checked at, available, reason): draw() runs on every redraw


def backend_warning(name: str) -> str:
    """Why the chosen backend cannot run here ('' when it can); Generate then falls back."""
    import time

    checked = _AVAILABILITY.get(name)
    if checked is None or time.monotonic() - checked[0] > 30:
        try:
            from ...lapig_core.lgst import BACKENDS

            cls = BACKENDS.get(name)
            ok, why = cls.availability() if cls else (False, f"unknown backend '{name}'")
        except ImportError as exc:
            ok, why = False, str(exc)
        checked = _AVAILABILITY[name] = (time.monotonic(), ok, why)
    return "" if checked[1] else checked[2]


def generate_blocker(scene) -> str:
    blocker = models_blocker(scene)
    if blocker:
        return blocker
    if not scene.lapig.style_override.strip() and not scene.lapig.prompt.strip():
        return "Type a prompt"
    return ""


def result_folder(scene) -> str:
    return storage.resolve_result_dir(scene.lapig.result_dir)


def result_state(scene) -> tuple[str, str]:
    s = scene.lapig
    folder = result_folder(scene)
    if not folder:
        return "MISSING", "No projector image yet"
    if s.result_fingerprint and _rig_now(s) not in (None, s.result_fingerprint):
        return "STALE", "The rig moved since this result"
    return "DONE", os.path.basename(folder)
