import json
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
    # refused before the benchmark's module (and torch) is imported, so with or without torch
    assert proc.returncode == 1 and "--camera must look like" in proc.stderr


@pytest.mark.blender
def test_headless_capture_of_a_saved_blend(lapig_registered, small_setup, tmp_path):
    import bpy

    blend = str(tmp_path / "rig.blend")
    s = bpy.context.scene.lapig
    s.target.name = "Wall ünïcode"
    s.ambient, s.gray_level = 0.06, 0.45  # the scene's room and references, which the command keeps
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    proc = _cli("capture", "--blend", blend, "--out", str(tmp_path / "data"), "--train", "2", "--test", "1",
                "--size", "32")
    assert proc.returncode == 0, proc.stderr[-2000:]
    # a non-ASCII object name becomes a safe folder name
    setup = tmp_path / "data" / "setups" / "Wall_n_code"
    assert (setup / "cam" / "warp" / "train" / "img_0002.png").exists()
    assert proc.stdout.strip().splitlines()[-1].startswith("{")
    meta = json.loads((setup / "setup.json").read_text())
    assert meta["ambient"] == pytest.approx(0.06) and meta["gray_level"] == pytest.approx(0.45)
    assert meta["counts"]["train"] == 2 and meta["working_size"] == 32


@pytest.mark.blender
@pytest.mark.torch
def test_eval_writes_sheet_and_metrics(tmp_path):

    from lapig.lapig_core.common.imageio import write_png
    from lapig.lapig_core.common.surfaces import make_surface

    surface = tmp_path / "wood surface.png"
    write_png(surface, make_surface("wood", size=128, seed=3))
    proc = _cli("eval", "--surface", str(surface), "--prompt", "Make it a stained glass artwork", "--out",
                str(tmp_path / "ev"), "--train", "8", "--iterations", "3", "--psa-iterations", "2",
                "--projector", "320x180", "--wall", "3.6x2", "--camera", "320x180", "--working-size", "64",
                "--refine", "2", timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    m = json.load(open(tmp_path / "ev" / "metrics.json"))
    # a wide facade: the whole 16:9 frame at 64x36, and the PSA look made and captured at 320x180
    native = m["native"]
    assert native["frame"] == [320, 180] and {"psnr", "ssim", "sharpness_ratio", "seconds"} <= set(native)
    assert native["on_object_fraction"] > 0.9 and native["psnr"] > 5
    assert (tmp_path / "ev" / "native_sheet.png").exists()
    for key in ("with_psa", "without_psa"):
        assert {"psnr", "rmse", "ssim", "iterations", "seconds"} <= set(m[key])
    assert m["with_psa"]["iterations"] <= 2 and {"ssim", "psnr"} <= set(m["style_retention"])
    assert {"capture_s", "train_s", "psa_s", "total_s"} <= set(m["timings"])
    assert (tmp_path / "ev" / "sheet.png").exists()
    # --refine: the PSA look refined on the rig, beside with_psa, measured on a fresh capture
    refined = m["with_refine"]
    assert {"psnr", "rmse", "ssim", "refine", "native_psnr"} <= set(refined)
    assert 1 <= refined["refine"]["iterations"] <= 2 and refined["psnr"] > m["with_psa"]["psnr"]
    assert refined["native_psnr"] > native["psnr"]  # the native output refined itself, measured at native size
    assert (tmp_path / "ev" / "refined_native_projector_image.png").exists()
    proc = _cli("eval", "--surface", str(tmp_path / "missing.png"), "--prompt", "x", "--out", str(tmp_path / "e2"))
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    proc = _cli("eval", "--surface", str(surface), "--prompt", "x", "--out", str(tmp_path / "e3"), "--output-size",
                "1000")
    assert proc.returncode == 1 and "larger than the projector's 800x600 frame" in proc.stderr
    proc = _cli("stylize", "--prompt", "  ")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr


@pytest.mark.blender
@pytest.mark.torch  # without torch, stylize first says that torch is missing
def test_stylize_refuses_a_bad_style_image_in_one_line(tmp_path):
    not_image = tmp_path / "painting.jpg"
    not_image.write_text("a letter, not a picture")
    proc = _cli("stylize", "--style-image", str(not_image))
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert f"error: {not_image} is not an image OpenCV can read" in proc.stderr
    proc = _cli("stylize", "--style-image", str(tmp_path / "gone.png:0.5"))
    assert proc.returncode == 1 and f"error: style image not found: {tmp_path / 'gone.png'}" in proc.stderr
    proc = _cli("stylize")
    assert proc.returncode == 1 and "stylize needs --prompt (or --style-image)" in proc.stderr
