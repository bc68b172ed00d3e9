# SPDX-License-Identifier: GPL-3.0-or-later
"""The fast path in Blender (issue 53, item 4): the prompt property's update and the timer that steps
services/generate/prompt_preview, whose debounce and cancel hold all the logic. Only where the one-step model is ready in the
model manager and the look is a diffusion one (services/generate/prompt_preview.fast_path_problem): otherwise typing a prompt
does what it always did. Generate stops the preview (the full PSA run's result must not be overwritten)."""
from __future__ import annotations

import bpy

from ..services.generate.prompt_preview import PreviewRequest, PromptPreview, PromptPreviewJob, fast_path_problem
from .timer_jobs import STEP_S, redraw

_session: dict = {}  # 'preview': this session's PromptPreview, 'scene': the name of the scene it previews


def _start_job(prompt: str):
    from . import preferences
    from .scene_store import scene_seams

    scene = bpy.data.scenes.get(_session.get("scene", "")) or bpy.context.scene
    request = PreviewRequest(prompt, preferences.ready_model("sd-turbo"), seed=scene.lapig.style_seed)
    return PromptPreviewJob(scene_seams(scene), request)


def _in_ui() -> bool:
    return not bpy.app.background  # scripts and the command line set prompts too: no preview there


def prompt_changed(settings, context) -> None:
    """scene.lapig.prompt's update: a preview DELAY_S after the last change, where the fast path is on."""
    from . import preferences

    if not _in_ui() or getattr(context, "scene", None) is None:
        return
    if fast_path_problem(settings.backend, preferences.ready_model("sd-turbo")):
        return
    preview = _session.get("preview")
    if preview is None:
        preview = _session["preview"] = PromptPreview(_start_job)
    _session["scene"] = context.scene.name
    preview.typed(settings.prompt)
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=STEP_S)


def _tick():
    """bpy.app.timers: one step of the previews; ends when nothing waits or runs."""
    preview = _session.get("preview")
    if preview is None:
        return None
    try:
        busy = preview.tick()
    except Exception as exc:  # a preview never stops the UI: its one line in the console
        from ..services.errors import one_line

        print(f"LAPIG: the prompt's preview failed: {one_line(exc)}")
        busy = False
    if preview.said:
        print(f"LAPIG: the prompt's preview: {preview.said}")
        preview.said = ""
    redraw({"VIEW_3D", "PROPERTIES"})
    return STEP_S if busy else None


def stop() -> None:
    """Generate begins (or the add-on goes): no preview waits, none lands afterwards."""
    preview = _session.get("preview")
    if preview is not None:
        preview.stop()


def register() -> None:
    pass  # nothing to register: the prompt property's update calls prompt_changed


def unregister() -> None:
    stop()
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    _session.clear()
