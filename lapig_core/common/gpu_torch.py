# SPDX-License-Identifier: GPL-3.0-or-later
"""Whether the installed torch can use a GPU, whether the computer has one, and the one command that installs
PyTorch's CUDA build into Blender's Python where it has an NVIDIA GPU and a CPU-only torch (no bpy, no torch:
the preferences ask on every redraw, and importing torch takes a second).

The zips carry torch's CPU build (tools/bundle.py): a CUDA build is several GB. The command puts the CUDA build
into the user's scripts/modules folder, which Blender puts on sys.path before the extensions' wheels, so it is
the torch found from the next start on.
"""
from __future__ import annotations

import importlib.util
import os
import platform
import re
import shutil
import sys
from dataclasses import dataclass

from .deps import REQUIRED

# PyTorch's own index of CUDA builds (the package index's Windows torch is CPU only, its Linux torch a CUDA build
# of its own choosing): CUDA 12.8 runs on the drivers of the last years and on every NVIDIA GPU since Maxwell
CUDA_INDEX = "https://download.pytorch.org/whl/cu128"
NVIDIA_DRIVER_PROC = "/proc/driver/nvidia"


@dataclass(frozen=True)
class TorchBuild:
    """The installed torch: its version, the CUDA version it was built for (None: no CUDA) and whether it has
    Apple's MPS."""
    present: bool
    version: str = ""
    cuda: str | None = None
    mps: bool = False

    @property
    def accelerated(self) -> bool:
        return bool(self.cuda) or self.mps

    def line(self) -> str:
        """'torch 2.13.0+cpu: CPU only', 'torch 2.13.0+cu128: CUDA 12.8', 'torch not installed'."""
        if not self.present:
            return "torch not installed"
        kinds = ([f"CUDA {self.cuda}"] if self.cuda else []) + (["Apple MPS"] if self.mps else [])
        return f"torch {self.version or '(version unknown)'}: {', '.join(kinds) or 'CPU only'}"


def installed_torch() -> TorchBuild:
    """What torch is installed, read from torch/version.py without importing torch (or from torch itself
    where it is imported already)."""
    torch = sys.modules.get("torch")
    if torch is not None and hasattr(torch, "version"):
        mps = getattr(torch.backends, "mps", None)
        return TorchBuild(True, str(torch.__version__), torch.version.cuda, bool(mps and mps.is_built()))
    spec = importlib.util.find_spec("torch")
    if spec is None or not spec.submodule_search_locations:
        return TorchBuild(False)
    folder = list(spec.submodule_search_locations)[0]
    try:
        with open(os.path.join(folder, "version.py"), encoding="utf-8") as f:
            text = f.read()
    except OSError:
        return TorchBuild(True)
    return TorchBuild(True, _assigned(text, "__version__") or "", _assigned(text, "cuda"), _macos_arm())


def _assigned(text: str, name: str) -> str | None:
    """The string value of `name = '...'` (or `name: Optional[str] = '...'`) in torch/version.py; None for
    None or a name that is not there."""
    match = re.search(rf"^{name}\s*(?::[^=]*)?=\s*['\"]([^'\"]*)['\"]", text, re.MULTILINE)
    return match.group(1) if match else None


def _macos_arm() -> bool:
    # torch's macOS wheels for Apple silicon are built with MPS; Intel Macs have none
    return sys.platform == "darwin" and platform.machine() == "arm64"


def nvidia_gpu_present(which=shutil.which, exists=os.path.exists) -> bool:
    """An NVIDIA driver is installed: nvidia-smi on PATH, or the driver's /proc folder (Linux)."""
    return bool(which("nvidia-smi")) or exists(NVIDIA_DRIVER_PROC)


def torch_requirement() -> str:
    """The torch pin the add-on is made for, e.g. 'torch==2.13.0'."""
    hint = next(hint for module, _, hint in REQUIRED if module == "torch")
    return hint.split(" ")[0]


def cuda_install_command(python_executable: str, target: str | None = None) -> str:
    """The pip command that installs PyTorch's CUDA build (the add-on's version) into Blender's Python, in
    deps.install_command's style; --upgrade replaces a CPU build already in the target folder."""
    where = f' --target "{target}"' if target else ""
    return (f'"{python_executable}" -m pip install --upgrade{where} --index-url {CUDA_INDEX} '
            f'"{torch_requirement()}"')


@dataclass(frozen=True)
class GpuAdvice:
    """What the preferences say about the GPU: a line on the installed torch, and, where an NVIDIA GPU has
    no CUDA torch to use it, why and the command that installs one."""
    line: str
    command: str = ""  # '' where there is nothing to install
    why: tuple = ()  # lines, each wrapped at the preferences' width


def gpu_advice(build: TorchBuild, gpu_present: bool, python_executable: str, target: str | None = None
               ) -> GpuAdvice:
    if build.accelerated or not gpu_present:
        return GpuAdvice(build.line())
    why = ("This computer has an NVIDIA GPU, but " + ("torch is not installed." if not build.present
                                                     else "this torch is a CPU build."),
           "Choose an NVIDIA CUDA build below and press Install: Train, PSA and the native output then run on "
           "the GPU (Device: Auto).")
    return GpuAdvice(build.line(), cuda_install_command(python_executable, target), why)
