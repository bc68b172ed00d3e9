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
import io
import os
import shutil
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


def _keep_previous(target: Path, tmp: Path, error) -> Path | None:
    """A hidden copy of the file at `target` (a hard link where the file system has them), named after its
    temporary file, for commit() to put back; None where there is no file yet."""
    if not target.exists():
        return None
    kept = tmp.with_name(tmp.name[:-len(TEMP_SUFFIX)] + ".previous" + TEMP_SUFFIX)
    with _reported(target, error):
        try:
            os.link(target, kept)
        except OSError:  # no hard links here (FAT, some network shares): a copy
            shutil.copyfile(target, kept)
    return kept


def _undo(done: list[Path], kept: dict) -> None:
    """Put the previous files back in place of the ones renamed there, newest first; remove the new ones."""
    for target in reversed(done):
        with contextlib.suppress(OSError):
            if kept[target] is not None:  # popped: should this fail, the previous file stays under its kept name
                os.replace(kept.pop(target), target)
            else:
                os.unlink(target)


def _remove(paths) -> None:
    for path in paths:
        if path is not None:
            with contextlib.suppress(OSError):
                os.unlink(path)


def temporary_beside(target, error=None) -> Path:
    """A new, empty hidden temporary file beside `target` (.<name>.XXXXXXXX.tmp), for a writer that streams
    into it (a video); commit(..., written=[(target, it)]) renames it into place. The folder must exist."""
    target = Path(target)
    with _reported(target, error):
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=TEMP_SUFFIX, dir=target.parent)
        os.close(fd)
        os.chmod(tmp_name, 0o644)
    return Path(tmp_name)


def commit(files: list[tuple[Path, bytes]], error=None, written=()) -> list[Path]:
    """Write every (path, bytes) to a temporary name first, then rename them all into place.

    `written`: (path, temporary file) pairs whose bytes a streaming writer already put in a
    temporary_beside() file; they are renamed after `files`, in order, and removed on a failure.

    Nothing appears under a final name until every byte of every file is written; a failure before
    that leaves no file behind. Renames go in the given order, so put the file that signals "done"
    last; if a rename fails, the ones already done are undone: the previous files are back, byte for
    byte (each is kept beside its target until the commit is through). The folders must exist.
    `error`: (OSError, path) -> the exception to raise instead (the OSError as its cause).
    """
    targets = [Path(target) for target, _ in files] + [Path(target) for target, _ in written]
    temps: list[Path] = []
    kept: dict[Path, Path | None] = {}  # target -> its previous file, kept under a temporary name
    done: list[Path] = []
    try:
        for target, (_, data) in zip(targets, files):
            temps.append(_write_temp(target, data, error))
            kept[target] = _keep_previous(target, temps[-1], error)
        for target, (_, tmp) in zip(targets[len(files):], written):
            temps.append(Path(tmp))
            kept[target] = _keep_previous(target, temps[-1], error)
        for target, tmp in zip(targets, temps):
            with _reported(target, error):
                os.replace(tmp, target)
            done.append(target)
    except BaseException:
        _undo(done, kept)
        _remove(temps + list(kept.values()))
        raise
    _remove(kept.values())
    return done


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write `data` to `path` whole or not at all (parent folders are created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    commit([(path, data)])
    return path


def atomic_write_npz(path, arrays: dict, compressed: bool = False) -> Path:
    """An .npz of `arrays` at exactly `path` (numpy would append .npz to other names), whole or not at all."""
    import numpy as np

    buf = io.BytesIO()
    (np.savez_compressed if compressed else np.savez)(buf, **arrays)
    return atomic_write_bytes(path, buf.getvalue())


def remove_partial_writes(path) -> None:
    """Remove the temporary files that killed atomic writes of ``path`` left beside it; for a
    writer that no other process writes ``path`` with meanwhile (one holding its folder's lock)."""
    path = Path(path)
    for partial in path.parent.glob(f".{glob.escape(path.name)}.*{TEMP_SUFFIX}"):
        with contextlib.suppress(OSError):
            partial.unlink()
