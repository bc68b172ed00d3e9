import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _cli(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", "lapig_addon", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)


@pytest.mark.parametrize("command", [[], ["demo"], ["capture"], ["dataset"], ["pretrain"], ["train"], ["stylize"],
                                     ["export"], ["eval"], ["bench"], ["build"]])
def test_every_command_has_help(command):
    proc = _cli(*command, "--help")
    assert proc.returncode == 0 and "usage:" in proc.stdout


@pytest.mark.blender
def test_bad_input_gives_one_line_and_no_traceback(tmp_path):
    proc = _cli("capture", "--blend", str(tmp_path / "missing.blend"), "--out", str(tmp_path))
    assert proc.returncode == 1
    assert "error: no such .blend file" in proc.stderr and "Traceback" not in proc.stderr
    proc = _cli("bench", "capture", "--camera", "big", "--out", str(tmp_path / "b"))
    assert proc.returncode == 1 and "--camera must look like" in proc.stderr


@pytest.mark.blender
def test_headless_capture_of_a_saved_blend(lapig_registered, small_setup, tmp_path):
    import bpy

    blend = str(tmp_path / "rig.blend")
    bpy.context.scene.lapig.target.name = "Wall ünïcode"
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    proc = _cli("capture", "--blend", blend, "--out", str(tmp_path / "data"), "--train", "2", "--test", "1",
                "--size", "32")
    assert proc.returncode == 0, proc.stderr[-2000:]
    # a non-ASCII object name becomes a safe folder name
    assert (tmp_path / "data" / "setups" / "Wall_n_code" / "cam" / "warp" / "train" / "img_0002.png").exists()
    assert proc.stdout.strip().splitlines()[-1].startswith("{")
