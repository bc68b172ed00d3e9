# SPDX-License-Identifier: GPL-3.0-or-later
"""The device setting (issue 37): 'auto' and 'cpu' made a torch.device with CUDA and MPS mocked, its one-line
description, the memory a GPU frame may take and the tiles that follow; the preferences' CUDA command (no
torch import); the commands' --device."""
import json
import subprocess
import sys
import pathlib

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.common import compute_device, gpu_torch  # noqa: E402
from lapig.lapig_core.native_output import device_tile, tile_for  # noqa: E402

pytestmark = pytest.mark.torch
ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture
def gpus(monkeypatch):
    """Set which accelerators torch reports: gpus(cuda=True, mps=False)."""
    def set_(cuda=False, mps=False):
        monkeypatch.setattr(torch.cuda, "is_available", lambda: cuda)
        monkeypatch.setattr(torch.backends.mps, "is_available", lambda: mps)
    set_()
    return set_


@pytest.mark.parametrize("cuda, mps, expected", [(False, False, "cpu"), (True, False, "cuda"), (False, True, "mps"),
                                                 (True, True, "cuda")])
def test_auto_takes_cuda_then_mps_else_the_cpu(gpus, cuda, mps, expected):
    gpus(cuda=cuda, mps=mps)
    assert compute_device.resolve("auto").type == expected
    assert compute_device.resolve(None).type == expected  # no choice: auto
    assert compute_device.resolve(" Auto ").type == expected
    assert compute_device.resolve("cpu") == torch.device("cpu")  # cpu whatever is there


def test_a_device_passes_through_and_an_unknown_name_is_refused(gpus):
    gpus(cuda=True)
    assert compute_device.resolve(torch.device("cuda", 1)) == torch.device("cuda", 1)
    assert compute_device.resolve("cuda:1") == torch.device("cuda", 1)
    assert compute_device.device_of(None) == torch.device("cpu")  # the library's default: the CPU
    with pytest.raises(ValueError, match="unknown device 'gpu': use auto or cpu"):
        compute_device.resolve("gpu")


def test_the_one_line_says_which_device(monkeypatch):
    assert compute_device.describe(None) == f"CPU: {torch.get_num_threads()} threads"
    assert compute_device.short_name("cpu") == "the CPU"
    monkeypatch.setattr(torch.cuda, "get_device_name", lambda device=None: "NVIDIA H200")
    cuda = torch.device("cuda")
    assert compute_device.describe(cuda) == f"CUDA: NVIDIA H200, torch {torch.__version__}"
    assert compute_device.short_name(cuda) == "CUDA (NVIDIA H200)"
    assert compute_device.describe(torch.device("mps")).startswith("MPS: Apple GPU, torch ")


def test_a_4k_frame_is_one_tile_where_the_gpu_has_the_memory(monkeypatch):
    free = {"bytes": 100 * 2 ** 30}
    monkeypatch.setattr(torch.cuda, "mem_get_info", lambda device=None: (free["bytes"], 141 * 2 ** 30))
    held = {"reserved": 0, "allocated": 0}  # torch's caching allocator: blocks it holds, and those in use
    monkeypatch.setattr(torch.cuda, "memory_reserved", lambda device=None: held["reserved"])
    monkeypatch.setattr(torch.cuda, "memory_allocated", lambda device=None: held["allocated"])
    cuda = torch.device("cuda")
    assert compute_device.memory_budget_mb(cuda) == pytest.approx(0.6 * 100 * 1024)
    held.update(reserved=12 * 2 ** 30, allocated=2 * 2 ** 30)  # 10 GiB cached after PSA: free for the frame too
    assert compute_device.memory_budget_mb(cuda) == pytest.approx(0.6 * 110 * 1024)
    held.update(reserved=0, allocated=0)
    assert compute_device.memory_budget_mb(torch.device("cpu")) is None
    assert device_tile(3840, 2160, cuda) == 3840  # an H200's free memory: the whole frame at once
    free["bytes"] = 4 * 2 ** 30  # a card Cycles holds: tiles, as the budget asks
    assert 128 <= device_tile(3840, 2160, cuda) < 2160
    assert device_tile(3840, 2160, torch.device("cpu")) == tile_for(3840, 2160)  # the computer's budget
    assert device_tile(3840, 2160, cuda, budget_mb=2000) == tile_for(3840, 2160, 2000)  # a budget given stands


def test_moved_puts_every_tensor_of_a_state_on_the_device():
    state = {"theta": [torch.ones(2), torch.zeros(1)], "tone_field": (torch.ones(1),), "describe": {"a": 1}}
    out = compute_device.moved(state, "cpu")
    assert out["theta"][0] is state["theta"][0]  # already there: the same tensor
    assert isinstance(out["tone_field"], tuple) and out["describe"] == {"a": 1}


# -- the preferences: whether torch can use the GPU, and the command that installs one that can ---------------

def _torch_version_file(tmp_path, monkeypatch, text):
    folder = tmp_path / "torch"
    folder.mkdir()
    (folder / "version.py").write_text(text)
    spec = type("Spec", (), {"submodule_search_locations": [str(folder)]})()
    monkeypatch.setattr(gpu_torch.importlib.util, "find_spec", lambda name: spec if name == "torch" else None)
    monkeypatch.delitem(sys.modules, "torch", raising=False)  # as in Blender before the first job
    monkeypatch.setattr(gpu_torch, "_macos_arm", lambda: False)


def test_the_installed_torch_is_read_without_importing_it(tmp_path, monkeypatch):
    _torch_version_file(tmp_path, monkeypatch, "from typing import Optional\n__version__ = '2.13.0+cpu'\n"
                                               "cuda: Optional[str] = None\n")
    cpu = gpu_torch.installed_torch()
    assert cpu == gpu_torch.TorchBuild(True, "2.13.0+cpu", None, False) and not cpu.accelerated
    assert cpu.line() == "torch 2.13.0+cpu: CPU only"
    (tmp_path / "torch" / "version.py").write_text("__version__ = '2.13.0+cu128'\ncuda: Optional[str] = '12.8'\n")
    cuda = gpu_torch.installed_torch()
    assert cuda.cuda == "12.8" and cuda.accelerated and cuda.line() == "torch 2.13.0+cu128: CUDA 12.8"
    monkeypatch.setattr(gpu_torch.importlib.util, "find_spec", lambda name: None)
    assert gpu_torch.installed_torch() == gpu_torch.TorchBuild(False)


def test_an_nvidia_gpu_is_found_by_nvidia_smi_or_the_drivers_proc_folder():
    assert gpu_torch.nvidia_gpu_present(which=lambda n: "/usr/bin/nvidia-smi", exists=lambda p: False)
    assert gpu_torch.nvidia_gpu_present(which=lambda n: None, exists=lambda p: p == "/proc/driver/nvidia")
    assert not gpu_torch.nvidia_gpu_present(which=lambda n: None, exists=lambda p: False)


def test_the_preferences_show_the_cuda_command_only_where_a_gpu_has_no_cuda_torch():
    cpu_build = gpu_torch.TorchBuild(True, "2.13.0+cpu")
    advice = gpu_torch.gpu_advice(cpu_build, True, "/blender/python/bin/python3.11", "/home/a/scripts/modules")
    assert advice.command == ('"/blender/python/bin/python3.11" -m pip install --upgrade --target '
                              '"/home/a/scripts/modules" --index-url https://download.pytorch.org/whl/cu128 '
                              '"torch==2.13.0"')
    assert advice.line == "torch 2.13.0+cpu: CPU only" and "CPU build" in advice.why[0]
    # the zips without torch (Linux, Blender 5.1+) say the same where there is a GPU
    none = gpu_torch.gpu_advice(gpu_torch.TorchBuild(False), True, "py", None)
    assert none.command == '"py" -m pip install --upgrade --index-url https://download.pytorch.org/whl/cu128 ' \
                           '"torch==2.13.0"' and "not installed" in none.why[0]
    assert gpu_torch.gpu_advice(cpu_build, False, "py").command == ""  # no GPU: nothing to install
    cuda_build = gpu_torch.TorchBuild(True, "2.13.0+cu128", "12.8")
    assert gpu_torch.gpu_advice(cuda_build, True, "py").command == ""  # the GPU is used already
    assert gpu_torch.gpu_advice(gpu_torch.TorchBuild(True, "2.13.0", mps=True), False, "py").command == ""


# -- the commands' --device --------------------------------------------------------------------------------

PARSE = """
import importlib.util, json, pathlib, sys
sys.modules['bpy'] = None  # as on a machine without Blender: the commands parse all the same
root = pathlib.Path.cwd()
sys.path[:] = [p for p in sys.path if pathlib.Path(p or '.').resolve() != root]
spec = importlib.util.spec_from_file_location('lapig', root / '__init__.py', submodule_search_locations=[str(root)])
package = importlib.util.module_from_spec(spec); sys.modules['lapig'] = package; spec.loader.exec_module(package)
from lapig.lapig_addon.cli.main import _parser
parser = _parser()
out = {' '.join(argv): getattr(parser.parse_args(argv), 'device', 'absent') for argv in ARGVS}
out['torch imported'] = 'torch' in sys.modules
print(json.dumps(out))
"""


def test_train_stylize_and_demo_take_device():
    argvs = [["train", "--device", "cpu"], ["train"], ["stylize", "--prompt", "x", "--device", "auto"],
             ["demo", "--device", "cpu"], ["export", "--out", "a.png"]]
    run = subprocess.run([sys.executable, "-c", PARSE.replace("ARGVS", repr(argvs))], capture_output=True,
                         text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    parsed = json.loads(run.stdout.strip().splitlines()[-1])
    assert parsed == {"train --device cpu": "cpu", "train": None, "stylize --prompt x --device auto": "auto",
                      "demo --device cpu": "cpu", "export --out a.png": "absent",
                      "torch imported": False}  # parsing stays cheap
    bad = subprocess.run([sys.executable, "-c", PARSE.replace("ARGVS", repr([["train", "--device", "gpu"]]))],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode == 2 and "invalid choice: 'gpu'" in bad.stderr


def test_train_recipe_on_a_gpu_takes_whole_images_for_the_compensation_alone():
    """finetune.device_recipe: whole images won 0.4 dB rendered on the corner and the bust; PCNet and the CPU as before."""
    from dataclasses import replace

    from lapig.lapig_core.photometric.finetune import cpu_recipe, device_recipe

    for device in (None, "cpu", torch.device("cpu")):
        assert device_recipe("CompenNeSt", "compensation", device=device) == cpu_recipe("CompenNeSt", "compensation")
    gpu = device_recipe("CompenNeSt", "compensation", 200, device=torch.device("cuda"))
    assert gpu == replace(cpu_recipe("CompenNeSt", "compensation", 200), crop=None)
    assert device_recipe("PCNet", "simulation", device="mps") == cpu_recipe("PCNet", "simulation")
