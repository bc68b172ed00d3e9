# SPDX-License-Identifier: GPL-3.0-or-later
"""Scratch folders of a running job (temporary renders, a result being written), and the removal
of those that a killed process left behind.

A scratch folder holds its own lock (common.locking) while its process uses it. One whose lock no
live process holds was left by a process that died: the next scratch folder made beside it removes
it. One without a lock file is being made this instant, or was left by a version without these
locks: it goes once it has not changed for an hour.
"""
from __future__ import annotations

import errno
import itertools
import os
import shutil
import tempfile
import time
from pathlib import Path

from .locking import FolderLock

UNLOCKED_MAX_AGE_S = 3600


class ScratchFolder:
    """<parent>/<prefix>XXXXXXXX, made exclusively, locked until remove() or move_to_new_folder()."""

    def __init__(self, parent, prefix: str):
        parent = Path(parent)
        parent.mkdir(parents=True, exist_ok=True)
        remove_abandoned(parent, prefix)
        self.path = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        self._lock = FolderLock(self.path, "LAPIG scratch folder").acquire()

    def remove(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)
        self._lock.release()

    def move_to_new_folder(self, name: str) -> Path:
        """Rename it into <parent>/<name>, or <name>_2, <name>_3, ... where that is taken: the
        folder appears complete, and never over another."""
        self._lock.release()  # its lock file must not go along
        for n in itertools.count(1):
            target = self.path.parent / (name if n == 1 else f"{name}_{n}")
            if target.exists():
                continue
            try:  # refused where the target exists (POSIX allows an empty folder, which no job leaves)
                os.rename(self.path, target)
            except OSError as exc:
                if exc.errno in (errno.EEXIST, errno.ENOTEMPTY):  # made by another job this instant
                    continue
                raise
            return target

    def replace_folder(self, target) -> Path:
        """Rename it into `target`, which may hold an earlier copy: that is moved aside first (hidden, beside
        it), removed after, and put back should the rename fail. The caller decides that `target` may go."""
        self._lock.release()  # its lock file must not go along
        target = Path(target)
        previous = None
        if target.exists():
            previous = self.path.with_name(self.path.name + ".previous")
            os.rename(target, previous)
        try:
            os.rename(self.path, target)
        except BaseException:
            if previous is not None:
                os.rename(previous, target)
            raise
        if previous is not None:
            shutil.rmtree(previous, ignore_errors=True)
        return target


def remove_abandoned(parent, prefix: str) -> list[Path]:
    """Remove the <parent>/<prefix>* scratch folders of processes that are gone; returns them."""
    removed = []
    for folder in sorted(Path(parent).glob(prefix + "*")):
        if not folder.is_dir() or folder.is_symlink():
            continue
        lock = FolderLock(folder, "LAPIG clean-up")
        try:
            lock.acquire(create=False)
        except FileNotFoundError:
            if _unchanged_for(folder) < UNLOCKED_MAX_AGE_S:
                continue
            shutil.rmtree(folder, ignore_errors=True)
        except OSError:  # FolderBusy: a live process's; PermissionError: another user's
            continue
        else:
            shutil.rmtree(folder, ignore_errors=True)
            lock.release()
        removed.append(folder)
    return removed


def _unchanged_for(folder: Path) -> float:
    try:
        return time.time() - folder.stat().st_mtime
    except OSError:  # removed meanwhile
        return 0.0
