"""Nothing lost: killed, interrupted and concurrent captures, and copied projects.

Each case runs the command line in a process of its own, as a user would, on a small rig
(projector 128x96, camera 160x120, working size 32, 24 training captures), and checks the message,
the exit status and what is on disk afterwards: the previous capture intact (byte for byte, and its
projector-capture correlation), no staging or temporary folder left once the next run is done, and
no file written anywhere else.
"""
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest
from rig_fixtures import small_rig

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.blender

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
KILL_DURING_COMMIT = os.path.join(ROOT, "tests", "blender", "kill_during_commit.py")
LEFT_BY_A_KILL = (".capture_staging/", ".lapig.lock")  # in the data root, until the next run

def _as_from_a_terminal():
    """In the child: Ctrl-C as a terminal delivers it. A test run started in the background of a script
    (`cmd &`) inherits SIGINT ignored, and Python then never raises KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)



def _tree(folder) -> dict:
    """Every file below ``folder``: relative path -> SHA-256."""
    return {os.path.relpath(os.path.join(d, f), folder).replace(os.sep, "/"):
            hashlib.sha256(open(os.path.join(d, f), "rb").read()).hexdigest()
            for d, _, files in os.walk(folder) for f in files}


def _correlation(folder) -> float:
    """Mean correlation between the training projector images and their registered captures."""
    from lapig.lapig_core.capture.dataset import load_capture_set

    cs = load_capture_set(folder)
    return float(np.mean([np.corrcoef(p.mean(-1).ravel(), c.mean(-1).ravel())[0, 1]
                          for p, c in zip(cs.prj_train, cs.cam_train)]))


def _seed_of(folder) -> str:
    from lapig.lapig_core.capture.dataset import load_capture_set

    return load_capture_set(folder).meta["pattern_source"]


class Project:
    """rig.blend, a capture of it with seed 1 in data/, and the state of everything."""

    def __init__(self, base):
        self.base, self.blend, self.data, self.tmp = base, str(base / "rig.blend"), str(base / "data"), base / "tmp"
        self.tmp.mkdir()
        self.env = dict(os.environ, TMPDIR=str(self.tmp))  # where the capture's renders go

    def record(self):
        self.files, self.correlation, self.others = _tree(self.data), _correlation(self.data), self._others()

    def _others(self) -> dict:
        return {k: v for k, v in _tree(self.base).items() if not k.startswith(("data", "tmp/"))}

    def capture(self, seed, out=None, stop_at=None, sig=signal.SIGKILL, command=()):
        """(exit status, stdout, stderr) of `capture` with ``seed``, sent ``sig`` once its output
        shows ``stop_at``; ``command``: what runs instead of `python -m lapig_addon`."""
        proc = self.start(seed, out, command)
        seen = []
        for line in proc.stdout:
            seen.append(line)
            if stop_at and stop_at in line:
                proc.send_signal(sig)
                break
        out, err = proc.communicate(timeout=120)
        return proc.returncode, "".join(seen) + out, err

    def start(self, seed, out=None, command=()):
        return subprocess.Popen([sys.executable, *(command or ["-m", "lapig_addon"]), "capture", "--blend",
                                 self.blend, "--out", out or self.data, "--seed", str(seed)],
                                cwd=ROOT, env=self.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                preexec_fn=_as_from_a_terminal)

    def assert_previous_capture_intact(self, leftovers=()):
        """The seed-1 set, byte for byte, loadable, as correlated; besides it only ``leftovers``
        in the data root, and nothing new anywhere else."""
        now = _tree(self.data)
        extra = {k for k in set(now) - set(self.files) if not k.startswith(leftovers)}
        assert not extra, f"files a capture left in the data root: {sorted(extra)[:5]}"
        assert {k: now[k] for k in self.files if k in now} == self.files, "the previous capture changed"
        assert _seed_of(self.data) == "generated (seed 1)"
        assert _correlation(self.data) == self.correlation > 0.7
        assert self._others() == self.others, "a file was written outside the data root"

    def temporary_folders(self) -> list:
        """LAPIG's in the temporary folder (a killed Blender leaves its own blender_* too)."""
        return sorted(p.name for p in self.tmp.iterdir() if not p.name.startswith("blender_"))


@pytest.fixture(scope="module")
def project(lapig_registered, tmp_path_factory):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.cli import headless

    base = tmp_path_factory.mktemp("reliability")
    scene = small_rig(base, projector_size=(128, 96))[0]
    s = scene.lapig
    s.train_count, s.test_count, s.working_size = 24, 0, 32
    bpy.ops.wm.save_as_mainfile(filepath=str(base / "rig.blend"))
    p = Project(base)
    headless.run_capture(scene, scene_state.capture_settings(scene, out_dir=p.data, seed=1))
    p.record()
    return p


@pytest.mark.parametrize("stop_at", ["capturing references", "structured light 8/", "writing references",
                                     "captures 16/24"], ids=["references", "gray code", "writing", "patterns"])
def test_a_capture_killed_at_any_point_leaves_the_previous_one_intact(project, stop_at):
    status, out, err = project.capture(2, stop_at=stop_at)
    assert status == -signal.SIGKILL and "capture complete" not in out
    project.assert_previous_capture_intact(leftovers=LEFT_BY_A_KILL)
    assert all(name.startswith("lapig_render_") for name in project.temporary_folders())


def test_a_kill_during_the_commit_is_finished_by_the_next_run(project):
    from lapig.lapig_core.capture import staging
    from lapig.lapig_core.capture.dataset import DatasetError, load_capture_set

    data = str(project.base / "data_commit")
    shutil.copytree(project.data, data)
    # 3 renames done: the new setup is in place, the old projector images only partly moved out
    status, out, _ = project.capture(2, out=data, command=[KILL_DURING_COMMIT, "3"])
    assert status == -signal.SIGKILL and "capture complete" not in out
    with pytest.raises(DatasetError, match="not the ones setup .* was captured with"):
        load_capture_set(data)  # neither set complete: refused, never a mixed one
    staging.hold_root(data, "LAPIG training").release()  # what the next capture or training does first
    assert _seed_of(data) == "generated (seed 2)" and _correlation(data) > 0.7
    assert not any(k.startswith(LEFT_BY_A_KILL) for k in _tree(data))


def test_ctrl_c_stops_a_capture_cleanly_and_clears_what_a_kill_left(project):
    project.capture(3, stop_at="captures 8/24")
    assert project.temporary_folders() and os.path.isdir(os.path.join(project.data, ".capture_staging"))
    status, out, err = project.capture(2, stop_at="captures 8/24", sig=signal.SIGINT)
    assert (status, err.strip()) == (130, "interrupted") and "capture complete" not in out
    project.assert_previous_capture_intact()  # and nothing else: the kill's staging is gone too
    assert project.temporary_folders() == []


def test_a_second_capture_into_the_same_folder_is_refused_at_once(project):
    data = str(project.base / "data_two")
    shutil.copytree(project.data, data)
    first = project.start(3, out=data)
    try:
        for line in first.stdout:  # until it holds the folder
            if "capturing references" in line:
                first.send_signal(signal.SIGSTOP)  # and keeps it, however slow the second one starts
                break
        status, out, err = project.capture(4, out=data)
    finally:
        first.send_signal(signal.SIGCONT)
    assert status == 1 and "structured light" not in out
    assert re.fullmatch(rf"error: {re.escape(data)} is in use by LAPIG capture \(pid {first.pid}, started "
                        r"[\d-]+ [\d:]+\): wait until it is done, or stop it\n", err)
    out, _ = first.communicate(timeout=120)
    assert first.returncode == 0 and "capture complete" in out
    assert _seed_of(data) == "generated (seed 3)" and _correlation(data) > 0.7
    assert not any(k.startswith(LEFT_BY_A_KILL) for k in _tree(data))
    assert project.temporary_folders() == []


@pytest.fixture(scope="module")
def saved_project(project, tmp_path_factory):
    """demo.blend with its capture in demo_lapig/ beside it, recorded by the Capture operator."""
    folder = tmp_path_factory.mktemp("projects") / "demo"
    folder.mkdir()
    bpy.ops.wm.open_mainfile(filepath=project.blend)
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "demo.blend"))
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    return folder


def _copy(project_folder, name) -> str:
    """A copy of the project folder (the .blend and its data folder); returns the copy's .blend."""
    copy = project_folder.parent / name
    shutil.copytree(project_folder, copy)
    return str(copy / "demo.blend")


def test_a_copied_project_uses_its_own_data(saved_project):
    from lapig.lapig_addon.blender import scene_state

    blend = _copy(saved_project, "copy")
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert bpy.context.scene.lapig.last_capture_dir.startswith("//demo_lapig/")  # as the capture recorded it
    capture = scene_state.read(bpy.context.scene).capture_dir
    assert capture.startswith(os.path.dirname(blend) + os.sep) and os.path.isdir(capture)


@pytest.mark.torch
def test_training_a_copied_old_project_with_absolute_paths_writes_into_the_copy(saved_project):
    original = _tree(saved_project)
    blend = _copy(saved_project, "old_copy")
    bpy.ops.wm.open_mainfile(filepath=blend)
    s = bpy.context.scene.lapig
    # as versions before relative paths stored it: the original's folder, absolute
    s.last_capture_dir = bpy.path.abspath(s.last_capture_dir).replace(os.path.dirname(blend), str(saved_project))
    assert os.path.isdir(s.last_capture_dir)
    bpy.ops.wm.save_mainfile()
    proc = subprocess.run([sys.executable, "-m", "lapig_addon", "train", "--blend", blend, "--iterations", "1",
                           "--save"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    capture = json.loads(proc.stdout.strip().splitlines()[-1])["capture"]
    assert capture.startswith(os.path.dirname(blend) + os.sep)
    assert os.path.isfile(os.path.join(capture, "models", "pcnet.pt"))
    assert _tree(saved_project) == original  # the original project, byte for byte
