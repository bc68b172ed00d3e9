"""What any failure says to the user: one line with its cause, for the command line and the operators."""
from __future__ import annotations

from ...lapig_core.rig import RigError

MAX_CHARS = 500

# refusals written for people (DatasetError, CheckpointError, CaptureError, ExportError, a missing file, a
# missing package): their message is the whole story. Anything else is a bug or a library's own error, and
# its type is part of the cause ("KeyError: 'arch'").
_WORDED = (ValueError, OSError, ImportError, RigError)  # RigError: a real device, worded for the installer


def one_line(exc: BaseException) -> str:
    if isinstance(exc, ModuleNotFoundError):  # "No module named 'torch'" says nothing about what to do
        from ...lapig_core.common.deps import missing_module_message

        if (worded := missing_module_message(exc.name)) is not None:
            return worded
    text = " ".join(str(exc).split())  # Blender's messages end in a newline, some span several
    # an operator's error report comes out of bpy.ops as RuntimeError("Error: ..."): worded for people too
    worded = isinstance(exc, _WORDED) or (isinstance(exc, RuntimeError) and text.startswith("Error: "))
    text = text.removeprefix("Error: ")
    if not worded or not text:
        text = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return text if len(text) <= MAX_CHARS else text[:MAX_CHARS - 1] + "…"
