"""The operators' one error boundary, and the file browser of the operators that ask for a folder.

Any exception in an operator's execute, invoke or modal becomes one ERROR report with its cause and
CANCELLED, never a traceback in the user's face; Blender started with --debug also prints the
traceback to the console. Every LAPIG operator derives from ReportsErrors, so none can miss it.
"""
from __future__ import annotations

import functools
import traceback

import bpy

from ..services.errors import one_line

ENTRY_POINTS = ("execute", "invoke", "modal")


def report_failure(operator, exc: BaseException, prefix: str = "") -> set:
    if bpy.app.debug:
        traceback.print_exception(exc)
    operator.report({"ERROR"}, prefix + one_line(exc))
    return {"CANCELLED"}


def reports_errors(method):
    """An operator's execute(self, context), or its invoke or modal(self, context, event), guarded."""
    # Blender checks that each method takes exactly its arguments, so the wrapper keeps the method's
    if method.__code__.co_argcount == 2:
        def guarded(self, context):
            try:
                return method(self, context)
            except Exception as exc:
                return report_failure(self, exc)
    else:
        def guarded(self, context, event):
            try:
                return method(self, context, event)
            except Exception as exc:
                return report_failure(self, exc)
    return functools.wraps(method)(guarded)


class ReportsErrors:
    """Mixin of every LAPIG operator: the entry points each class defines are guarded (reports_errors)."""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        for name in ENTRY_POINTS:
            if name in cls.__dict__:
                setattr(cls, name, reports_errors(cls.__dict__[name]))


class AsksForFolder(ReportsErrors):
    """Mixin of an operator that works on a folder: invoke shows the file browser, Blender then calls
    execute() with self.directory."""

    directory: bpy.props.StringProperty(subtype="DIR_PATH")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


def show_in_image_editor(operator, context, image, elsewhere: str) -> None:
    """`image` in the screen's first Image Editor; without one, the INFO line `elsewhere` says where to find it."""
    for area in (context.screen.areas if context.screen else []):
        if area.type == "IMAGE_EDITOR":
            area.spaces.active.image = image
            return
    operator.report({"INFO"}, elsewhere)


def refuse(reason: str) -> None:
    """Stop with `reason` (a blocker's sentence) where there is one: ReportsErrors (or the command line) says it
    in one line."""
    if reason:
        raise ValueError(reason)


def report_notes(operator, notes):
    """Notes about a result (a cut prompt, a weak match, a fallback) as warnings the user sees."""
    for note in notes:
        operator.report({"WARNING"}, note)


def poll_reason(cls, reason: str) -> bool:
    """An operator's poll(): True when `reason` is '' ; else Blender greys the button out and its tooltip (and a
    script's error) says `reason` (poll_message_set: Blender 3.0 and later)."""
    if reason:
        cls.poll_message_set(reason)
        return False
    return True
