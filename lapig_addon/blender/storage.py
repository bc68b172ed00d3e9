"""Where captures, weights and results live: a folder next to the .blend, or a temporary one."""
from __future__ import annotations

import os
import re
import tempfile

import bpy

FOLDER_SUFFIX = "_lapig"


def data_root() -> tuple[str, bool]:
    """(folder, is_temporary). Saved files keep data in '<name>_lapig' beside the .blend."""
    blend = bpy.data.filepath
    if blend:
        stem = os.path.splitext(os.path.basename(blend))[0]
        return os.path.join(os.path.dirname(blend), stem + FOLDER_SUFFIX), False
    return os.path.join(tempfile.gettempdir(), f"lapig_unsaved_{os.getpid()}"), True


def setup_name_for(object_name: str) -> str:
    """A file-system-safe setup folder name from the surface object's name."""
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", object_name).strip("._") or "setup"
    return name[:64]


def location_message() -> str:
    folder, temporary = data_root()
    if temporary:
        return "Unsaved file: data goes to a temporary folder (save the .blend to keep it)"
    return f"Data folder: {folder}"


def capture_root(setup_name: str) -> str:
    """Each object's captures get a data set root of their own: the public layout shares projector
    images between the setups of one root, and each capture may use its own patterns."""
    return os.path.join(data_root()[0], setup_name)


def resolve_capture_dir(path: str) -> str:
    """The capture folder, found again beside the .blend when the file and its data folder moved."""
    if not path:
        return ""
    name = os.path.basename(os.path.normpath(bpy.path.abspath(path)))
    return _resolve(path, os.path.join(name, "setups"))


def resolve_result_dir(path: str) -> str:
    return _resolve(path, "results")


def _resolve(path: str, kind: str) -> str:
    if not path:
        return ""
    absolute = bpy.path.abspath(path)
    if os.path.isdir(absolute):
        return absolute
    moved = os.path.join(data_root()[0], kind, os.path.basename(os.path.normpath(absolute)))
    return moved if os.path.isdir(moved) else ""
