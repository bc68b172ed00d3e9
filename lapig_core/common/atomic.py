# SPDX-License-Identifier: GPL-3.0-or-later
"""Files that appear whole or not at all: every write goes to a hidden temporary file beside the
target (.<name>.XXXXXXXX.tmp) and is renamed into place only once all its bytes are written.

A full disk or a crash mid-write leaves the previous file (or nothing), never a truncated one. No
fsync: ENOSPC surfaces at write or close, before the rename, and an fsync per file would slow down
captures of thousands of images. The one implementation for images, checkpoints, setup.json,
result.json, the compensator choice and the export's PNG and sidecar.
"""
from __future__ import annotations

import contextlib
import glob
import os
import tempfile
from pathlib import Path

TEMP_SUFFIX = ".tmp"


def write_all(handle, data: bytes) -> None:
    """The actual write, kept apart so that tests can simulate a full disk here."""
    handle.write(data)


@contextlib.contextmanager
def _reported(target: Path, error):
    """An OSError about `target` raised as error(exc, target) (from it), or as it is without `error`."""
    try:
        yield
    except OSError as exc:
        if error is None:
            raise
        raise error(exc, target) from exc


def _write_temp(target: Path, data: bytes, error) -> Path:
    """`data` in a hidden temporary file beside `target`; removed again on any failure."""
    with _reported(target, error):
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=TEMP_SUFFIX, dir=target.parent)
    try:
        with _reported(target, error):
            with os.fdopen(fd, "wb") as handle:
                write_all(handle, data)  # ENOSPC surfaces here or at close
            os.chmod(tmp_name, 0o644)  # mkstemp makes it private; the result is an ordinary file
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp_name)
        raise
    return Path(tmp_name)


def commit(files: list[tuple[Path, bytes]], error=None) -> list[Path]:
    """Write every (path, bytes) to a temporary name first, then rename them all into place.

    Nothing appears under a final name until every byte of every file is written; a failure before
    that leaves no file behind. Renames go in the given order, so put the file that signals "done"
    last; if a rename fails, the ones already done are undone. The folders must exist. `error`:
    (OSError, path) -> the exception to raise instead (the OSError as its cause).
    """
    temps: list[Path] = []
    done: list[Path] = []
    try:
        for target, data in files:
            temps.append(_write_temp(Path(target), data, error))
        for (target, _), tmp in zip(files, temps):
            with _reported(Path(target), error):
                os.replace(tmp, target)
            done.append(target)
    except BaseException:
        for path in temps + done:
            with contextlib.suppress(OSError):
                os.unlink(path)
        raise
    return done


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write `data` to `path` whole or not at all (parent folders are created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    commit([(path, data)])
    return path


def remove_partial_writes(path) -> None:
    """Remove the temporary files that killed atomic writes of ``path`` left beside it; for a
    writer that no other process writes ``path`` with meanwhile (one holding its folder's lock)."""
    path = Path(path)
    for partial in path.parent.glob(f".{glob.escape(path.name)}.*{TEMP_SUFFIX}"):
        with contextlib.suppress(OSError):
            partial.unlink()
