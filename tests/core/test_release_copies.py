"""The captures and results release 0.1.0 wrote (tests/data/release_0_1_0, made by tools/release_copies.py) are
read by today's lapig_core as they are: no migration was needed (issue 51 item 3). The Blender side (its .blend
files, the export of its results to the same pixels, a new look on its captures): tests/blender/test_release_copies_in_blender.py.
"""
import json
import pathlib

import numpy as np
import pytest

RELEASE = pathlib.Path(__file__).resolve().parents[1] / "data" / "release_0_1_0"
MADE = json.loads((RELEASE / "MADE_BY.json").read_text(encoding="utf-8"))


def test_the_releases_capture_of_one_projector_loads_with_its_first_look():
    """Its classical first look, read back, still predicts its own captures (0.0035 RMS when written)."""
    from lapig.lapig_core.capture.dataset import load_capture_set, read_setup_json, resolve_setup
    from lapig.lapig_core.photometric.classical import ClassicalModel

    folder = RELEASE / MADE["copies"]["one"]["capture"]
    assert read_setup_json(resolve_setup(folder).setup_json)["projector"]["width"] == 64
    model = ClassicalModel.load(folder / "models" / "classical.npz")
    cs = load_capture_set(folder, frame=(model.shape[1], model.shape[0]))
    assert cs.cam_train.shape == (4, 48, 64, 3)
    rms = float(np.sqrt(((model.simulate(cs.prj_train) - cs.cam_train) ** 2).mean()))
    assert rms == pytest.approx(model.residual, abs=1e-5) and rms < 0.01


def test_the_releases_capture_of_two_projectors_loads_with_its_joint_model():
    """Its joint model, read back, predicts the first projector's capture alone where that projector reaches."""
    from lapig.lapig_core.multi.capture_set import is_multi, joint_model_path, load_multi_capture
    from lapig.lapig_core.multi.joint_model import JointModel

    folder = RELEASE / MADE["copies"]["two"]["capture"]
    assert is_multi(folder)
    cs = load_multi_capture(folder)
    assert cs.sizes == ((64, 48), (64, 48)) and cs.captures[0].shape == (4, 60, 80, 3)
    model = JointModel.load(joint_model_path(cs.setup_dir))
    assert model.count == 2 and model.shape == (60, 80)
    reached = model.reached[0] & cs.object_mask
    assert reached.mean() > 0.5
    predicted = model.predict([cs.frames[0][0], None])
    error = predicted - cs.captures[0][0].astype(np.float32) / 255
    assert float(np.sqrt((error[reached] ** 2).mean())) < 0.01  # 0.0018 when written


@pytest.mark.parametrize("name", ["one", "two"])
def test_the_releases_results_read_as_they_are(name):
    from lapig.lapig_core.export.result_files import read_output_image, read_summary
    from lapig.lapig_core.multi.result_files import is_multi_result

    folder = RELEASE / MADE["copies"][name]["result"]
    summary = read_summary(folder)
    assert summary["prompt"] == MADE["prompt"]
    assert is_multi_result(folder) == (name == "two")
    if name == "one":
        assert read_output_image(folder, "projector").shape[:2] == (48, 64)
    else:
        assert [p["image"] for p in summary["projectors"]] == ["projector_1.png", "projector_2.png"]
