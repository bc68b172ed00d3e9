"""The real-rig options of the headless commands on a .blend rigged through the operators: a capture
through a simulated real rig (the Cycles studio behind a camera with latency and faults), the refusals
of an incomplete or unreachable real rig, each one line with the .blend left as it was."""
import json
import os

import pytest

from test_headless_chain import _cli, _json, rigged_blend  # noqa: F401 (the fixture)

pytestmark = [pytest.mark.blender]


def test_a_simulated_real_rig_captures_with_every_bad_frame_caught(rigged_blend):
    out = _json(_cli("capture", "--blend", rigged_blend, "--rig", "simulated", "--sim-latency", "0.1",
                     "--sim-faults", "0.05", "--train", "4", "--save"))
    assert out["rig"] == "simulated rig" and out["sync"]["frame_code"] == "verified, top and bottom bands"
    assert out["sync"]["latency_s"] >= 0.1 and out["registration_error_px_median"] < 1.0
    meta = json.load(open(os.path.join(out["setup_dir"], "setup.json")))
    assert meta["device"] == "simulated rig" and meta["health"]["problems"] == []
    assert meta["device_timing"]["latency_s"] >= 0.1 and "objects" in meta


def test_an_incomplete_or_unreachable_real_rig_is_refused_in_one_line(rigged_blend, tmp_path):
    before = open(rigged_blend, "rb").read()
    said = _cli("capture", "--blend", rigged_blend, "--rig", "real", "--save")
    assert said.returncode == 1 and said.stderr.strip() == \
        "error: --rig real needs --display and --camera (or --tethered DIR): 'devices' lists them"
    said = _cli("capture", "--blend", rigged_blend, "--display", "1")
    assert said.returncode == 1 and "go with --rig real" in said.stderr
    env_display = os.environ.pop("DISPLAY", None)
    try:
        said = _cli("capture", "--blend", rigged_blend, "--rig", "real", "--display", "1", "--camera",
                    str(tmp_path / "missing.avi"), "--save")
    finally:
        if env_display is not None:
            os.environ["DISPLAY"] = env_display
    # no screen here (the desktop-less SDL drivers are refused), or no SDL2 at all (the torch-free tier's venv)
    assert said.returncode == 1 and said.stderr.startswith("error: the projector window did not open on display '1': ")
    assert "there is no screen here" in said.stderr or "install the pip packages pysdl2" in said.stderr
    assert "Traceback" not in said.stderr and len(said.stderr.strip().splitlines()) == 1
    assert open(rigged_blend, "rb").read() == before  # nothing saved


def test_show_needs_a_display_and_a_result(rigged_blend):
    said = _cli("show", "--blend", rigged_blend)
    assert said.returncode == 1 and "show needs --display" in said.stderr
    said = _cli("show", "--blend", rigged_blend, "--display", "1")
    assert said.returncode == 1 and "the scene has no result yet" in said.stderr


@pytest.mark.torch
@pytest.mark.parametrize("faults", ["0", "0.1"])
def test_the_whole_chain_on_a_simulated_real_rig(rigged_blend, tmp_path, faults):
    """capture, train, stylize with refinement and export on --rig simulated, each exit 0, in a row."""
    rig = ("--rig", "simulated", "--sim-latency", "0.05", "--sim-faults", faults)
    captured = _json(_cli("capture", "--blend", rigged_blend, *rig, "--test", "2", "--save"))
    assert captured["registration_error_px_median"] < 1.0
    trained = _json(_cli("train", "--blend", rigged_blend, *rig, "--save"))
    assert os.path.normpath(trained["capture"]) == os.path.normpath(captured["setup_dir"])
    assert "in captures on the rig 'simulated rig' of" in trained["compensation"], trained["compensation"]
    # the .blend's own rig is the studio the simulated rig's optics were: it renders the choice too
    again = _json(_cli("train", "--blend", rigged_blend, "--iterations", "2"))
    assert "in Cycles captures of" in again["compensation"], again["compensation"]
    styled = _json(_cli("stylize", "--blend", rigged_blend, *rig, "--mix", "charcoal_wash:1", "--prompt",
                        "charcoal", "--no-psa", "--refine", "2", "--save"))
    assert 1 <= styled["refine"]["iterations"] <= 2
    exported = _json(_cli("export", "--blend", rigged_blend, "--out", str(tmp_path / "projector.png")))
    assert os.path.isfile(exported["image"])


def test_frames_faulty_beyond_rescue_are_one_line_and_the_previous_capture_stays(rigged_blend):
    first = _json(_cli("capture", "--blend", rigged_blend, "--rig", "simulated", "--sim-faults", "0", "--save"))
    setup = first["setup_dir"]
    before = {name: open(os.path.join(setup, name), "rb").read() for name in ("setup.json",)}
    blend_before = open(rigged_blend, "rb").read()
    said = _cli("capture", "--blend", rigged_blend, "--rig", "simulated", "--sim-faults", "0.3", "--save")
    assert said.returncode == 1 and "Traceback" not in said.stderr, said.stderr[-2000:]
    assert len(said.stderr.strip().splitlines()) == 1, said.stderr
    assert said.stderr.startswith("error: the camera's frames cannot be verified: "), said.stderr
    assert {name: open(os.path.join(setup, name), "rb").read() for name in before} == before
    assert open(rigged_blend, "rb").read() == blend_before
