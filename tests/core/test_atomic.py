# SPDX-License-Identifier: GPL-3.0-or-later
"""atomic.commit: every file written whole or not at all, and a commit that fails midway undone."""
import os

import pytest

from lapig.lapig_core.common import atomic


def _rename_fails(monkeypatch, nth: int) -> None:
    """The commit's rename number ``nth`` fails as a full disk would."""
    renames, replace = [], os.replace

    def failing(src, dst):
        renames.append(dst)
        if len(renames) == nth:
            raise OSError(28, "No space left on device")
        replace(src, dst)

    monkeypatch.setattr(atomic.os, "replace", failing)


def test_a_failed_third_rename_of_five_leaves_the_five_files_as_they_were(tmp_path, monkeypatch):
    targets = [tmp_path / f"file_{i}.bin" for i in range(5)]
    for i, path in enumerate(targets):
        path.write_bytes(f"previous {i}".encode() * (i + 1))
    before = {path.name: path.read_bytes() for path in targets}
    _rename_fails(monkeypatch, 3)
    with pytest.raises(OSError, match="No space left"):
        atomic.commit([(path, f"new {i}".encode()) for i, path in enumerate(targets)])
    monkeypatch.undo()
    assert {path.name: path.read_bytes() for path in targets} == before
    assert sorted(os.listdir(tmp_path)) == sorted(before)  # no temporary file left beside them


def test_a_failed_commit_removes_the_files_it_created(tmp_path, monkeypatch):
    old, new = tmp_path / "old.bin", tmp_path / "new.bin"
    old.write_bytes(b"previous")
    _rename_fails(monkeypatch, 2)
    with pytest.raises(OSError):
        atomic.commit([(new, b"created"), (old, b"replaced")])
    monkeypatch.undo()
    assert sorted(os.listdir(tmp_path)) == ["old.bin"] and old.read_bytes() == b"previous"
