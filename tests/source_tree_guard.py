"""A run's writes into the checkout, found by comparing the source tree before and after it.

Tests write into tmp_path; a file that appears in, changes in or vanishes from the checkout during a run is
a test reaching into the source tree (a result written beside the code, a cache kept in build/), which makes
runs depend on each other and dirties a user's clone. Folders that tools own are left out.
"""
from __future__ import annotations

import os
import pathlib

# owned by git, the environments, Python and pytest themselves
SKIPPED_FOLDERS = {".git", ".venv", ".venvs", "__pycache__", ".pytest_cache"}


def snapshot(root: pathlib.Path) -> dict[str, tuple[int, int]]:
    """Every file under root (skipped folders aside) -> (size, modification time in ns)."""
    files = {}
    for folder, subfolders, names in os.walk(root):
        subfolders[:] = [name for name in subfolders if name not in SKIPPED_FOLDERS]
        for name in names:
            path = pathlib.Path(folder, name)
            try:
                stat = path.lstat()
            except FileNotFoundError:  # removed while walking
                continue
            files[path.relative_to(root).as_posix()] = (stat.st_size, stat.st_mtime_ns)
    return files


def changes(before: dict, after: dict) -> list[str]:
    """'added PATH', 'changed PATH' and 'removed PATH' lines, sorted by path."""
    lines = []
    for path in sorted(set(before) | set(after)):
        if path not in before:
            lines.append(f"added {path}")
        elif path not in after:
            lines.append(f"removed {path}")
        elif before[path] != after[path]:
            lines.append(f"changed {path}")
    return lines
