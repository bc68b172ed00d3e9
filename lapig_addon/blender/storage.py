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


def stored_path(folder) -> str:
    """How the scene records a data folder: relative to the .blend ('//...') when it lies in the
    data folder beside it, so that a copy of the project uses the copy of its data; else absolute."""
    folder = os.path.abspath(folder)
    root, temporary = data_root()
    return bpy.path.relpath(folder) if not temporary and _inside(folder, os.path.abspath(root)) else folder


def _inside(folder: str, root: str) -> bool:
    try:
        return os.path.commonpath([folder, root]) == root
    except ValueError:  # another drive
        return False


def resolve_capture_dir(path: str) -> str:
    """The capture folder, found again beside the .blend when the file and its data folder moved."""
    if not path:
        return ""
    name = os.path.basename(os.path.normpath(bpy.path.abspath(path)))
    return _resolve(path, (name, "setups", name))


def resolve_result_dir(path: str) -> str:
    if not path:
        return ""
    return _resolve(path, ("results", os.path.basename(os.path.normpath(bpy.path.abspath(path)))))


def _resolve(path: str, in_data_root: tuple) -> str:
    """The folder `path` names, or the one of the same name in the data folder beside this .blend.
    The one beside wins over an absolute path into another data folder (a file saved before paths
    were relative, then copied with its data): the copy must not write into the original."""
    absolute = os.path.normpath(bpy.path.abspath(path))
    beside = os.path.join(data_root()[0], *in_data_root)
    candidates = [absolute, beside]
    its_data_root = absolute
    for _ in in_data_root:
        its_data_root = os.path.dirname(its_data_root)
    if not path.startswith("//") and its_data_root.endswith(FOLDER_SUFFIX):
        candidates.reverse()
    return next((folder for folder in candidates if os.path.isdir(folder)), "")
