# SPDX-License-Identifier: GPL-3.0-or-later
"""Where a diffusion model runs, in which precision, and whether it fits there, before it is loaded.

The device is compute_device's choice (CUDA, then Apple's MPS, else the CPU; 'cpu' forces the CPU). Half
precision (float16) on CUDA and MPS, which run it natively; float32 on the CPU, where float16 is slow or
unsupported. The memory need is estimated from the weights' bytes on disk (the files hold float32 or
float16: their bytes scaled to the chosen precision), plus a working margin for the activations at 512 px
(on the CPU without accelerate, twice the weights: loading holds a random copy beside the file's);
the free memory is the GPU's (CUDA: free now; MPS: the recommended working set less what torch holds) or,
on the CPU, the computer's available memory. One line says the result, and why it does not fit.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from .catalogue import ModelError

ACTIVATION_MARGIN = 1.25  # the weights' bytes times this, plus WORKING_MB
WORKING_MB = {"cuda": 1200.0, "mps": 1200.0, "cpu": 1500.0}


@dataclass
class DevicePlan:
    device: str  # 'cuda', 'mps', 'cpu'
    name: str  # 'CUDA (NVIDIA H100)', 'MPS', 'the CPU'
    dtype: str  # 'float16', 'float32'
    needed_mb: float
    free_mb: float | None  # None: not known here
    fits: bool

    def line(self, title: str = "the model") -> str:
        free = "free memory not known" if self.free_mb is None else f"{self.free_mb / 1024:.1f} GB free"
        if self.fits:
            return f"{title} runs on {self.name} in {self.dtype}: needs about {self.needed_mb / 1024:.1f} GB, {free}"
        hint = "close other programs" + (" or leave the GPU to Cycles and choose the CPU in the preferences"
                                         if self.device != "cpu" else "")
        return (f"{title} does not fit on {self.name}: it needs about {self.needed_mb / 1024:.1f} GB in "
                f"{self.dtype}, {free}: {hint}")


def half_precision(device: str) -> bool:
    return device in ("cuda", "mps")


def available_memory_mb(device) -> float | None:
    """Free memory where the model would live, in MB (None where this system does not say)."""
    import torch

    if device.type == "cuda":
        free, _ = torch.cuda.mem_get_info(device)
        return free / 2 ** 20
    if device.type == "mps":
        try:
            return (torch.mps.recommended_max_memory() - torch.mps.driver_allocated_memory()) / 2 ** 20
        except (AttributeError, RuntimeError):
            return None
    return system_available_mb()


def system_available_mb() -> float | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    try:
        import psutil  # macOS, Windows, where it is installed
        return psutil.virtual_memory().available / 2 ** 20
    except ImportError:
        return None


def _loads_twice() -> bool:
    """Without accelerate, diffusers builds each network with random weights, then loads the file's: both are in
    the computer's memory at once while it loads."""
    import importlib.util

    return importlib.util.find_spec("accelerate") is None


def needed_mb(weights_bytes: int, dtype: str, device: str, stored_half: bool = False) -> float:
    scale = (0.5 if dtype == "float16" else 1.0) * (2.0 if stored_half else 1.0)
    margin = 2.0 if device == "cpu" and _loads_twice() else ACTIVATION_MARGIN
    return weights_bytes * scale * margin / 2 ** 20 + WORKING_MB[device]


def plan(weights_bytes: int, choice="auto", stored_half: bool = False, free_mb: float | None = -1.0) -> DevicePlan:
    """The device and precision for a model of `weights_bytes`, and whether it fits (free_mb: the free memory,
    for tests; -1 asks the system)."""
    from ..common import compute_device

    device = compute_device.resolve(choice)
    dtype = "float16" if half_precision(device.type) else "float32"
    need = needed_mb(weights_bytes, dtype, device.type, stored_half)
    free = available_memory_mb(device) if free_mb == -1.0 else free_mb
    return DevicePlan(device.type, compute_device.short_name(device), dtype, round(need, 1),
                      None if free is None else round(free, 1), free is None or free >= need)


def require_fit(folder: str, choice="auto", title: str = "the model", free_mb: float | None = -1.0) -> DevicePlan:
    """The plan for the pipeline in `folder`; ModelError with its one line where it does not fit."""
    from .pipeline_folder import weights_bytes

    size = weights_bytes(folder)
    half = _stored_half(folder)
    result = plan(size, choice, stored_half=half, free_mb=free_mb)
    if not result.fits:
        raise ModelError(result.line(title))
    return result


def _stored_half(folder: str) -> bool:
    """Whether the UNet's weights file is float16 (an fp16 copy of a model): a safetensors header says."""
    import json
    import struct

    path = os.path.join(folder, "unet", "diffusion_pytorch_model.safetensors")
    try:
        with open(path, "rb") as f:
            length = struct.unpack("<Q", f.read(8))[0]
            header = json.loads(f.read(min(length, 1 << 24)))
    except (OSError, ValueError, struct.error):
        return False
    dtypes = {v.get("dtype") for k, v in header.items() if k != "__metadata__" and isinstance(v, dict)}
    return dtypes == {"F16"}
