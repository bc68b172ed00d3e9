# SPDX-License-Identifier: GPL-3.0-or-later
"""Which torch device the heavy work runs on (Train, PSA, the style backends, the native output).

The artist chooses 'auto' (CUDA, then Apple's MPS, else the CPU) or 'cpu' (the add-on's preferences,
`--device` on the commands); `resolve` makes it a torch.device, `describe` says in one line which device
ran, for the models line, result.json and the commands' JSON. The library's functions take a
torch.device or None; None is the CPU, as it was before there was a choice, so a caller that passes
nothing gets the CPU's results bit for bit.
"""
from __future__ import annotations

import torch

AUTO, CPU = "auto", "cpu"
CHOICES = (AUTO, CPU)
# share of a GPU's free memory one frame's work may take: the rest stays for the caches of the allocator,
# the style nets and whatever else (Blender's viewport, Cycles) holds memory on that card
GPU_MEMORY_SHARE = 0.6


def mps_available() -> bool:
    mps = getattr(torch.backends, "mps", None)
    return bool(mps is not None and mps.is_available())


def resolve(choice=AUTO) -> torch.device:
    """'auto' (or None): CUDA where torch sees a GPU, else MPS, else the CPU; 'cpu': the CPU; a
    torch.device (or 'cuda:1', 'mps') as it is. ValueError for anything else."""
    if isinstance(choice, torch.device):
        return choice
    name = (choice or AUTO).strip().lower()
    if name == AUTO:
        if torch.cuda.is_available():
            return torch.device("cuda")
        if mps_available():
            return torch.device("mps")
        return torch.device("cpu")
    if name == CPU:
        return torch.device("cpu")
    if name.split(":")[0] in ("cuda", "mps"):
        return torch.device(name)
    raise ValueError(f"unknown device {choice!r}: use {' or '.join(CHOICES)}")


def device_of(device) -> torch.device:
    """A library function's `device` argument as a torch.device (None: the CPU)."""
    return torch.device("cpu") if device is None else resolve(device)


def describe(device) -> str:
    """One line: 'CUDA: NVIDIA H200, torch 2.13.0+cu128', 'MPS: Apple GPU, torch 2.13.0',
    'CPU: 2 threads'."""
    device = device_of(device)
    if device.type == "cuda":
        return f"CUDA: {torch.cuda.get_device_name(device)}, torch {torch.__version__}"
    if device.type == "mps":
        return f"MPS: Apple GPU, torch {torch.__version__}"
    return f"CPU: {torch.get_num_threads()} threads"


def short_name(device) -> str:
    """The device in a few words, for the panel's lines: 'the CPU', 'CUDA (NVIDIA H200)', 'MPS'."""
    device = device_of(device)
    if device.type == "cuda":
        return f"CUDA ({torch.cuda.get_device_name(device)})"
    return "MPS" if device.type == "mps" else "the CPU"


def memory_budget_mb(device) -> float | None:
    """The memory one frame's work may take on `device`, in MB: GPU_MEMORY_SHARE of a CUDA device's free
    memory now; None elsewhere (the caller's budget for the computer's memory stands). Free counts the blocks
    torch's caching allocator holds without using them (Train and PSA leave some): the driver counts them taken."""
    device = device_of(device)
    if device.type != "cuda":
        return None
    free, _ = torch.cuda.mem_get_info(device)
    cached = max(0, torch.cuda.memory_reserved(device) - torch.cuda.memory_allocated(device))
    return GPU_MEMORY_SHARE * (free + cached) / 2 ** 20


def synchronize(device) -> None:
    """Wait for the device's queued work, so a timing counts it (a no-op on the CPU)."""
    device = device_of(device)
    if device.type == "cuda":
        torch.cuda.synchronize(device)
    elif device.type == "mps":
        torch.mps.synchronize()


def module_device(module: torch.nn.Module) -> torch.device:
    """Where a module's weights (or buffers) are; the CPU for one with neither."""
    for tensor in list(module.parameters()) + list(module.buffers()):
        return tensor.device
    return torch.device("cpu")


def moved(value, device):
    """`value` with every tensor in it (nested in dicts, lists and tuples) on `device`; other values as they
    are. Tensors already there are the same objects."""
    if isinstance(value, torch.Tensor):
        return value.to(device)
    if isinstance(value, dict):
        return {k: moved(v, device) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(moved(v, device) for v in value)
    return value
