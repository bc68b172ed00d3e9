"""The networks' activations on the CPU are channels-last (NHWC); what they take and give stays NCHW.

With NCHW tensors, torch's oneDNN convolutions reorder each layer's input into oneDNN's blocked layout and its
output back: in a Train step at 64 px crops those reorders took 40 % of oneDNN's time. With NHWC activations they
read and write the tensors as they are. Measured on 2 AMD cores (BENCHMARKS "Channels-last activations on the
CPU", `bench layout`): the same figures to float rounding, 4 % off Train's step and 7-9 % off PSA and a 1080p
compensation. Other devices keep NCHW (not measured there)."""
from __future__ import annotations

import torch


def into(t: torch.Tensor) -> torch.Tensor:
    """A network's 4D input as it runs on the CPU: channels-last (a copy where it is not already)."""
    if t.dim() != 4 or t.device.type != "cpu":
        return t
    return t.contiguous(memory_format=torch.channels_last)


def out_of(t: torch.Tensor) -> torch.Tensor:
    """A network's output as its callers expect it: NCHW-contiguous (views, .numpy() and the files as before)."""
    if t.dim() != 4 or t.device.type != "cpu":
        return t
    return t.contiguous()
