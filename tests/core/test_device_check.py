# SPDX-License-Identifier: GPL-3.0-or-later
"""The prepared device check (issue 37, tools/device_check.sh): its shipped capture, the CPU figures stored
beside it, and its parity arithmetic. The check itself takes minutes; here only what it stands on."""
import json
import subprocess
import sys
import pathlib

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.capture.dataset import load_capture_set  # noqa: E402
from lapig.tools.bench import bench_device  # noqa: E402
from lapig.tools.bench.device_fixture import FIXTURE, TEST, TRAIN  # noqa: E402

pytestmark = pytest.mark.torch
ROOT = pathlib.Path(__file__).resolve().parents[2]
ISSUE_KEYS = ("device", "gpu_train_seconds", "gpu_train_seconds_paper_recipe", "gpu_psa_seconds",
              "gpu_compensate_fps_4k", "gpu_parity_db")


def test_the_shipped_capture_loads_as_the_app_loads_one():
    cs = load_capture_set(FIXTURE)
    assert cs.frame_size == (128, 96) and len(cs.prj_train) == TRAIN and len(cs.prj_test) == len(cs.cam_test) == TEST
    assert cs.projector_valid is not None and cs.projector_valid.mean() > 0.9
    square = bench_device.resized_capture(cs, 256)  # the paper's recipe trains on 256 px squares
    assert square.prj_train.shape == (TRAIN, 256, 256, 3) and square.cam_gray.shape == (256, 256, 3)
    assert square.projector_valid.shape == (256, 256)


def test_the_cpu_figures_beside_the_fixture_have_the_issues_keys_and_the_machines_speed():
    cpu = json.loads(bench_device.CPU_FIGURES.read_text())
    assert all(key in cpu for key in ISSUE_KEYS) and cpu["device"].startswith("CPU: ")
    assert cpu["torch_step_s"] and cpu["note"] and not cpu["quick_run"]
    assert set(cpu["prompts"]) == set(bench_device.MIXES)
    assert all(row["simulated_psnr"] > 10 and row["simulated_psnr_capped"] > 10 for row in cpu["prompts"].values())
    assert cpu["train_choice"]["learned_psnr"] is not None


def test_parity_is_the_devices_psnr_less_the_cpus():
    cpu = {"prompts": {"a": {"simulated_psnr": 30.0, "simulated_psnr_nopsa": 25.0}},
           "train_choice": {"learned_psnr": 28.0}}
    rows = {"a": {"simulated_psnr": 30.05, "simulated_psnr_nopsa": 24.9}}
    same = bench_device.parity(rows, {"learned_psnr": 28.02}, cpu)
    assert same["gpu_parity_db"] == pytest.approx(0.05) and same["parity_ok"]
    assert same["parity_db"] == pytest.approx({"psa": 0.05, "nopsa": -0.1, "train": 0.02})
    rows["a"]["simulated_psnr"] = 29.8  # 0.2 dB off: not within the tenth of a dB
    assert not bench_device.parity(rows, {"learned_psnr": 28.02}, cpu)["parity_ok"]
    assert bench_device.parity(rows, {}, None)["gpu_parity_db"] is None  # no CPU figures: said, not guessed
    # where both ran PSA with its stop rule off, that figure is compared: a stop an iteration apart is no fault
    cpu["prompts"]["a"]["simulated_psnr_capped"], rows["a"]["simulated_psnr_capped"] = 31.0, 31.02
    assert bench_device.parity(rows, {"learned_psnr": 28.02}, cpu)["parity_db"]["psa"] == pytest.approx(0.02)


def test_the_launcher_needs_no_blender():
    code = ("import runpy, sys\nsys.modules['bpy'] = None\nsys.argv = ['tools/device_check.py', '--help']\n"
            "runpy.run_path('tools/device_check.py', run_name='__main__')\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert "--paper-iterations" in run.stdout and "--write-cpu-figures" in run.stdout


def test_the_subnormal_cost_check_runs_each_condition_on_its_own_thread(monkeypatch):
    """bench denormals (part of the check), one step per condition: the shipped PCNet's subnormals are counted,
    its Adam moments go subnormal without flush-to-zero and stay clean with it."""
    from lapig.tools.bench import bench_denormals

    monkeypatch.setattr(bench_denormals, "STEPS", 1)
    monkeypatch.setattr(bench_denormals, "ROUNDS", 1)
    out = bench_denormals.time_network(load_capture_set(FIXTURE), "PCNet", "simulation")
    assert set(out["step_ms"]) == set(bench_denormals.CONDITIONS) and min(out["step_ms"].values()) > 0
    moments = out["subnormal_moments_after_2_steps"]
    if not out["flush_supported"]:
        pytest.skip("this CPU has no flush-to-zero mode")
    assert moments["flush"] == moments["now"] == 0
    assert moments["scrubbed"] > 0  # scrubbing the weights alone leaves the moments' squares


def test_on_a_gpu_the_parity_compares_the_cpus_recipe_and_train_is_timed_with_its_own(monkeypatch):
    """On a GPU Train's compensation fine-tunes on whole images (finetune.device_recipe) while the CPU's stored
    figures come from 64 px crops: the parity's models must come from a Train with the CPU's recipe."""
    calls = []

    def fake_time_train(cs, device, iterations=None, recipe_of=None):
        calls.append((device.type, None if recipe_of is None else recipe_of.type))
        return {"trained": "models", "train_choice": {"learned_psnr": 30.0}, "gpu_train_seconds": 1.0}

    monkeypatch.setattr(bench_device, "time_train", fake_time_train)
    own = {"trained": "own models"}
    assert bench_device.train_for_parity(None, torch.device("cpu"), 2, own) is own and calls == []
    same = bench_device.train_for_parity(None, torch.device("cuda"), 2, own)
    assert calls == [("cuda", "cpu")] and same["trained"] == "models"


def test_train_follows_the_recipe_of_the_device_it_is_given(monkeypatch):
    """train_models(recipe_of=...): the GPU's recipe run on the CPU fine-tunes the compensation on whole images;
    the CPU's, 64 px crops (the device code path, on a machine without a GPU)."""
    from lapig.lapig_core import pipeline

    cs = load_capture_set(FIXTURE)
    crops, real = [], pipeline.finetune

    def spy(cs, arch, role, recipe=None, **kw):
        crops.append((arch, recipe.crop))
        return real(cs, arch, role, recipe=recipe, **kw)

    monkeypatch.setattr(pipeline, "finetune", spy)
    gpu_recipe = pipeline.train_models(cs, save=False, iterations=2, recipe_of=torch.device("cuda"))
    assert crops == [("CompenNeSt", None), ("PCNet", 64)]
    assert gpu_recipe["device"].startswith("CPU: ")  # trained here, whatever recipe it followed
    crops.clear()
    pipeline.train_models(cs, save=False, iterations=2, recipe_of=torch.device("cpu"))
    assert crops == [("CompenNeSt", 64), ("PCNet", 64)]


def test_a_gpu_machine_whose_torch_has_no_cuda_is_told_not_timed_on_the_cpu():
    cpu = torch.device("cpu")
    assert "has no CUDA" in bench_device.gpu_missed("auto", cpu, gpu_present=True)
    assert "PYTHON=python3" in bench_device.gpu_missed("auto", cpu, gpu_present=True)
    assert bench_device.gpu_missed("auto", cpu, gpu_present=False) == ""  # no GPU: the CPU is the device
    assert bench_device.gpu_missed("cpu", cpu, gpu_present=True) == ""  # the CPU asked for
    with bench_device.full_float32(cpu):  # nothing to change on the CPU
        pass
    assert bench_device.warm_up(None, cpu) is False


def test_the_parity_runs_switch_tf32_off_and_back():
    flags = torch.backends.cudnn, torch.backends.cuda.matmul  # torch's settings, also on a CPU build
    saved = tuple(f.allow_tf32 for f in flags)
    try:
        flags[0].allow_tf32, flags[1].allow_tf32 = True, False  # torch's defaults
        with bench_device.full_float32(torch.device("cuda")):
            assert not flags[0].allow_tf32 and not flags[1].allow_tf32
        assert flags[0].allow_tf32 and not flags[1].allow_tf32
    finally:
        flags[0].allow_tf32, flags[1].allow_tf32 = saved
