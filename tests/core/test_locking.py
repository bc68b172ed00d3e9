# SPDX-License-Identifier: GPL-3.0-or-later
"""The folder lock (one job per data root) and the scratch folders of live processes."""
from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import time

import pytest

from lapig.lapig_core.common import scratch
from lapig.lapig_core.common.locking import LOCK_FILE, FolderBusy, FolderLock

ROOT = pathlib.Path(__file__).resolve().parents[2]
HOLD = ("import sys, time; from lapig_core.common.locking import FolderLock; "
        "FolderLock(sys.argv[1], 'LAPIG training').acquire(); print('held', flush=True); time.sleep(60)")


@pytest.fixture
def holder_process():
    """Start a process that takes a folder's lock and keeps it until killed."""
    started = []

    def start(folder):
        proc = subprocess.Popen([sys.executable, "-c", HOLD, str(folder)], cwd=ROOT, stdout=subprocess.PIPE,
                                text=True)
        started.append(proc)
        assert proc.stdout.readline().strip() == "held"
        return proc

    yield start
    for proc in started:
        proc.kill()
        proc.wait()


def test_a_lock_is_taken_released_and_leaves_nothing(tmp_path):
    folder = tmp_path / "new" / "data"
    with FolderLock(folder, "LAPIG capture"):
        assert (folder / LOCK_FILE).is_file()
    assert folder.is_dir() and list(folder.iterdir()) == []
    with FolderLock(folder, "LAPIG capture"):  # and taken again
        pass


def test_a_second_job_of_the_same_process_is_refused_naming_the_first(tmp_path):
    with FolderLock(tmp_path, "LAPIG capture"):
        with pytest.raises(FolderBusy) as refused:
            FolderLock(tmp_path, "LAPIG training").acquire()
    message = str(refused.value)
    assert message.startswith(f"{tmp_path} is in use by LAPIG capture (pid {os.getpid()}, started 20")
    assert "\n" not in message
    FolderLock(tmp_path, "LAPIG training").acquire().release()  # free again once the first is done


def test_the_lock_does_not_outlive_a_killed_process(tmp_path, holder_process):
    proc = holder_process(tmp_path)
    with pytest.raises(FolderBusy, match=rf"in use by LAPIG training \(pid {proc.pid}, started "):
        FolderLock(tmp_path, "LAPIG capture").acquire()
    proc.kill()  # SIGKILL: no clean-up of its own
    proc.wait()
    assert (tmp_path / LOCK_FILE).exists()  # a killed process cannot remove its file, but its lock is gone
    with FolderLock(tmp_path, "LAPIG capture"):
        pass
    assert not (tmp_path / LOCK_FILE).exists()


def test_scratch_folders_of_dead_processes_go_and_those_of_live_ones_stay(tmp_path, holder_process):
    live_here = scratch.ScratchFolder(tmp_path, "lapig_render_")
    live_elsewhere = tmp_path / "lapig_render_other"
    holder = holder_process(live_elsewhere)
    dead = tmp_path / "lapig_render_killed"
    killed = holder_process(dead)
    (dead / "chunk_00001").mkdir()
    killed.kill()
    killed.wait()
    being_made = tmp_path / "lapig_render_new"  # no lock file yet
    being_made.mkdir()
    from_an_old_version = tmp_path / "lapig_render_old"
    from_an_old_version.mkdir()
    hour_ago = time.time() - scratch.UNLOCKED_MAX_AGE_S - 1
    os.utime(from_an_old_version, (hour_ago, hour_ago))
    unrelated = tmp_path / "other_render_x"
    unrelated.mkdir()

    assert scratch.remove_abandoned(tmp_path, "lapig_render_") == [dead, from_an_old_version]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [live_here.path.name, "lapig_render_other", "lapig_render_new", "other_render_x"])
    assert holder.poll() is None
    live_here.remove()
    assert not live_here.path.exists()


def test_a_scratch_folder_moves_into_a_name_no_other_folder_has(tmp_path):
    (tmp_path / "look").mkdir()
    (tmp_path / "look" / "result.json").write_text("{}")
    folders = []
    for _ in range(2):
        made = scratch.ScratchFolder(tmp_path, ".writing_")
        (made.path / "result.json").write_text("{}")
        folders.append(made.move_to_new_folder("look"))
    assert [f.name for f in folders] == ["look_2", "look_3"]
    assert all(sorted(p.name for p in f.iterdir()) == ["result.json"] for f in folders)  # no lock file along
    assert sorted(p.name for p in tmp_path.iterdir()) == ["look", "look_2", "look_3"]
