# SPDX-License-Identifier: GPL-3.0-or-later
"""The torch builds the preferences' Install button offers, and where pip finds each (no bpy).

PyTorch publishes one package index per build (CPU, each CUDA and ROCm release); macOS takes torch from the
ordinary package index, whose wheels for Apple silicon have MPS. The version is the add-on's pin
(requirements.txt, deps.REQUIRED): a local label such as 2.13.0+cpu meets torch==2.13.0.
LAPIG_TORCH_INDEX_URL replaces the build's index (a company mirror, or the local index of the tests).
"""
from __future__ import annotations

import os
import platform
import sys
from dataclasses import dataclass

from ....lapig_core.common.gpu_torch import torch_requirement

INDEX_ENV = "LAPIG_TORCH_INDEX_URL"
PYTORCH_INDEX = "https://download.pytorch.org/whl/"


@dataclass(frozen=True)
class Build:
    key: str  # the preference's enum value
    label: str
    description: str  # the tooltip
    index: str | None  # PyTorch's index for it; None: the ordinary package index (pip's own configuration)
    platforms: tuple  # sys.platform prefixes it exists for
    size_note: str  # what the user downloads, roughly


BUILDS = (
    Build("CPU", "CPU", "Runs everywhere; Train and Generate take minutes on the CPU",
          PYTORCH_INDEX + "cpu", ("linux", "win32"), "about 200 MB"),
    Build("CUDA128", "NVIDIA CUDA 12.8", "NVIDIA GPUs since Maxwell, on drivers of the last years (570 or later)",
          PYTORCH_INDEX + "cu128", ("linux", "win32"), "about 3 GB with its CUDA libraries"),
    Build("CUDA130", "NVIDIA CUDA 13.0", "Newer NVIDIA GPUs and drivers (580 or later)",
          PYTORCH_INDEX + "cu130", ("linux", "win32"), "about 3 GB with its CUDA libraries"),
    Build("ROCM", "AMD ROCm 7.1", "AMD GPUs that ROCm supports (Linux only)",
          PYTORCH_INDEX + "rocm7.1", ("linux",), "about 4 GB with its ROCm libraries"),
    Build("MAC", "macOS (Apple MPS)", "torch for macOS: the GPU of Apple silicon through MPS, else the CPU",
          None, ("darwin",), "about 80 MB"),
)


def builds_for(platform_name: str = sys.platform) -> list[Build]:
    """The builds there are for this operating system (sys.platform's value)."""
    return [b for b in BUILDS if any(platform_name.startswith(p) for p in b.platforms)]


def build(key: str) -> Build:
    found = next((b for b in BUILDS if b.key == key), None)
    if found is None:
        raise ValueError(f"no torch build '{key}': choose one of {', '.join(b.key for b in BUILDS)}")
    return found


def default_build(platform_name: str = sys.platform, nvidia_gpu: bool = False) -> str:
    """What the preferences offer first: CUDA where an NVIDIA GPU is, the macOS build on a Mac, else CPU."""
    keys = [b.key for b in builds_for(platform_name)]
    if "MAC" in keys:
        return "MAC"
    return "CUDA128" if nvidia_gpu and "CUDA128" in keys else "CPU"


def unsupported_reason(platform_name: str = sys.platform, machine: str | None = None) -> str:
    """Why no build installs here ('' where one does): PyTorch publishes no wheels for Intel Macs any more."""
    machine = machine or platform.machine()
    if platform_name == "darwin" and machine not in ("arm64", "aarch64"):
        return "PyTorch publishes no torch 2.13 for Intel Macs: LAPIG's networks need an Apple silicon Mac"
    if not builds_for(platform_name):
        return f"no torch build is known for {platform_name}"
    return ""


def index_args(chosen: Build, env=os.environ) -> list[str]:
    """pip's arguments that say where the build comes from."""
    override = (env.get(INDEX_ENV) or "").strip()
    if override:
        return ["--index-url", override]
    return ["--index-url", chosen.index] if chosen.index else []


def requirement() -> str:
    return torch_requirement()
