# SPDX-License-Identifier: GPL-3.0-or-later
"""An exclusive lock on a folder: one job of one live process writes there at a time.

The lock is an OS lock on <folder>/.lapig.lock (flock on POSIX, msvcrt.locking on Windows), which
the kernel drops when its process dies: a killed job never leaves its folder locked. It belongs to
the open file, not to the process, so a second job of the same process is refused too. The file
says who holds it (job title, pid, start time), for the message that refuses the next job, and is
removed when the lock is released.
"""
from __future__ import annotations

import datetime
import json
import os
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None
    import msvcrt

LOCK_FILE = ".lapig.lock"
_WINDOWS_LOCK_OFFSET = 1 << 30  # msvcrt locks a byte range: one far past the holder's note, which stays readable


class FolderBusy(OSError):
    """Another job holds the folder's lock."""


class FolderLock:
    """``with FolderLock(folder, "LAPIG capture"):`` or acquire() ... release()."""

    def __init__(self, folder, title: str):
        self.folder, self.title = Path(folder), title
        self.path = self.folder / LOCK_FILE
        self._fd = None

    def acquire(self, create: bool = True) -> "FolderLock":
        """Take the lock, or raise FolderBusy naming its holder. create=False: only the lock of an
        existing lock file (FileNotFoundError when there is none)."""
        if create:
            self.folder.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | (os.O_CREAT if create else 0), 0o644)
            if not _try_lock(fd):
                os.close(fd)
                raise FolderBusy(f"{self.folder} is in use by {holder_of(self.path)}: wait until it is done, "
                                 f"or stop it")
            if _is_current(fd, self.path):
                break
            # its holder removed the file between our open and our lock: lock the new one
            _unlock(fd)
            os.close(fd)
            if not create:
                raise FileNotFoundError(self.path)
        note = {"title": self.title, "pid": os.getpid(),
                "started": datetime.datetime.now().isoformat(sep=" ", timespec="seconds")}
        os.lseek(fd, 0, os.SEEK_SET)
        os.ftruncate(fd, 0)
        os.write(fd, json.dumps(note).encode("utf-8"))
        self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        # removed while still held, so a job that opened it meanwhile sees a stale file (acquire)
        removed = _remove(self.path)
        _unlock(self._fd)
        os.close(self._fd)
        self._fd = None
        if not removed:  # Windows removes no open file
            _remove(self.path)

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()


def holder_of(lock_path) -> str:
    """Who a lock file says holds it: 'LAPIG capture (pid 4242, started 2026-01-01 12:00:00)'."""
    try:
        note = json.loads(Path(lock_path).read_text(encoding="utf-8"))
        return f"{note['title']} (pid {note['pid']}, started {note['started']})"
    except (OSError, ValueError, TypeError, KeyError):  # being written this instant, or not ours
        return "another LAPIG job"


def _try_lock(fd) -> bool:
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        else:
            os.lseek(fd, _WINDOWS_LOCK_OFFSET, os.SEEK_SET)
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
    except OSError:
        return False
    return True


def _unlock(fd) -> None:
    if fcntl is not None:
        fcntl.flock(fd, fcntl.LOCK_UN)
    else:
        os.lseek(fd, _WINDOWS_LOCK_OFFSET, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_UNLCK, 1)


def _is_current(fd, path: Path) -> bool:
    try:
        return os.path.samestat(os.fstat(fd), os.stat(path))
    except FileNotFoundError:
        return False


def _remove(path: Path) -> bool:
    try:
        path.unlink()
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return True
