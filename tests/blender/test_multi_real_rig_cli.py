"""A real rig of two projectors, simulated (two windows with a real rig's timing and faults over the Cycles studio
of both projectors, one camera), through the whole chain on the command line: capture, the joint first look,
stylize with one step of refinement, export (images and MPCDI), and show live on two windows of the virtual
two-monitor X screen, each exiting 0 in a row. Bad input: two projectors on one display, and a display that goes
mid-capture, each one line with the previous capture kept."""
import json
import os

import pytest

from test_headless_chain import _cli, _json, rigged_blend  # noqa: F401 (the fixture)

pytestmark = [pytest.mark.blender]

SIM = ("--rig", "simulated", "--sim-latency", "0.05", "--sim-faults", "0.03")
SIZE = (160, 120)  # each projector's; the virtual screens' monitors are made this size for show


@pytest.fixture
def two_projector_blend(rigged_blend):
    import bpy

    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    bpy.ops.wm.save_as_mainfile(filepath=rigged_blend)
    return rigged_blend


@pytest.fixture
def two_small_monitors():
    from lapig.tools import virtual_screens

    if virtual_screens.missing_tools():
        pytest.skip("needs " + "; ".join(virtual_screens.missing_tools()))
    monitors = [(0, 0, *SIZE), (SIZE[0], 0, *SIZE)]
    with virtual_screens.two_monitors(monitors=monitors, root_size=(2 * SIZE[0], SIZE[1])) as env:
        yield env, monitors


@pytest.mark.torch
@pytest.mark.display
def test_two_windows_and_one_camera_through_the_whole_chain(two_projector_blend, tmp_path, two_small_monitors):
    blend = two_projector_blend
    captured = _json(_cli("capture", "--blend", blend, *SIM, "--train", "4", "--save"))
    meta = json.load(open(os.path.join(captured["setup_dir"], "setup.json")))
    assert meta["device"] == "simulated rig" and meta["multi"]["count"] == 2
    assert [p["sync"]["frame_code"] for p in meta["projectors"]] == ["verified, top and bottom bands"] * 2
    assert all(p["health"]["problems"] == [] and p["sync"]["latency_s"] >= 0.05 for p in meta["projectors"])
    assert captured["first_look"]["line"] and captured["coverage"]["reached"] > 0.5, captured
    styled = _json(_cli("stylize", "--blend", blend, *SIM, "--prompt", "Make it a stained glass artwork",
                        "--refine", "1", "--save"))
    assert styled["refine"]["iterations"] == 1, styled
    exported = _json(_cli("export", "--blend", blend, "--out", str(tmp_path / "out" / "look.png"), "--mpcdi",
                          str(tmp_path / "out" / "rig.mpcdi")))
    assert len(exported["images"]) == 2 and os.path.isfile(tmp_path / "out" / "rig.mpcdi"), exported
    env, monitors = two_small_monitors
    import subprocess
    import sys

    from test_headless_chain import ROOT

    shown = subprocess.run([sys.executable, "-m", "lapig_addon", "show", "--blend", blend, "--display", "0,1",
                            "--seconds", "0", "--lock-frames", "20"], cwd=ROOT, capture_output=True, text=True,
                           timeout=300, env=env)
    out = _json(shown)
    assert [d["index"] for d in out["displays"]] == [0, 1]
    assert out["lock"]["frames"] == 20 and out["lock"]["max_skew_frames"] <= 1.0, out["lock"]


def test_two_projectors_on_one_display_are_one_line(two_projector_blend):
    import bpy

    s = bpy.context.scene.lapig
    s.rig_kind, s.real.display, s.real.camera = "REAL", "1", "0"
    s.extra_projectors[0].display = "1"
    bpy.ops.wm.save_as_mainfile(filepath=two_projector_blend)
    before = open(two_projector_blend, "rb").read()
    said = _cli("capture", "--blend", two_projector_blend)
    assert said.returncode == 1 and len(said.stderr.strip().splitlines()) == 1, said.stderr
    assert said.stderr.strip().endswith("are both on display '1': give each its own display"), said.stderr
    said = _cli("show", "--blend", two_projector_blend, "--result", "/nonexistent")
    assert said.returncode == 1 and "Traceback" not in said.stderr
    assert open(two_projector_blend, "rb").read() == before


def test_a_display_that_goes_mid_capture_stops_it_and_the_previous_capture_stays(two_projector_blend):
    first = _json(_cli("capture", "--blend", two_projector_blend, *SIM, "--train", "3", "--save"))
    setup = first["setup_dir"]
    before = open(os.path.join(setup, "setup.json"), "rb").read()
    blend_before = open(two_projector_blend, "rb").read()
    said = _cli("capture", "--blend", two_projector_blend, *SIM, "--train", "3", "--sim-display-gone", "80", "--save")
    assert said.returncode == 1 and "Traceback" not in said.stderr, said.stderr[-2000:]
    assert len(said.stderr.strip().splitlines()) == 1, said.stderr
    assert "its display is gone (unplugged or switched off)" in said.stderr, said.stderr
    assert open(os.path.join(setup, "setup.json"), "rb").read() == before
    assert open(two_projector_blend, "rb").read() == blend_before
