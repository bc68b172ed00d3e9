"""The networks' activations on the CPU are channels-last (NHWC); what they take and give stays NCHW.

With NCHW tensors, torch's oneDNN convolutions reorder each layer's input into oneDNN's blocked layout and its
output back: in a Train step at 64 px crops those reorders took 40 % of oneDNN's time. With NHWC activations they
read and write the tensors as they are. Measured on 2 AMD cores (BENCHMARKS "Channels-last activations on the
CPU", `bench layout`): the same figures to float rounding, 4 % off Train's step and 7-9 % off PSA and a 1080p
compensation. Other devices keep NCHW (not measured there).

Both layouts are right on every CPU: in float64 they agree to 1e-15, and in float32 each stays within float rounding
of a float64 run. Where they differ more (PCNet's image gradient by 4.9e-4 of its norm with oneDNN's AVX2 kernels
in NCHW, on CPUs without AVX-512), a pre-activation within rounding of 0 fell on the other side of a ReLU's kink:
a tie broken differently, which moved PSA's simulated PSNR by 0.0015 dB (BENCHMARKS, "Layouts on CPUs without
AVX-512"). Channels-last stays because it is the faster one."""
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
