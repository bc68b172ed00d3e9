# SPDX-License-Identifier: GPL-3.0-or-later
"""Subnormal floats kept out of torch's CPU work.

Why: weights that training drives towards zero end up subnormal (below 1.2e-38 in float32): the shipped
pretrained CompenNeSt has 1,298 of them (0.16 %), PCNet's fine-tune makes thousands more, and Adam's second
moment of a weight whose gradient is that small is subnormal too (7 % of PCNet's after 300 iterations).
Many Intel cores take a microcode assist of 100-200 cycles on every vector instruction with a subnormal
operand or result; AMD's Zen cores take none (measured here: a 64-channel convolution costs the same with 0,
0.2 or 20 % subnormal weights). One subnormal weight in a vector of 16 is enough, so a fraction of a percent
of them can make a convolution several times slower on such a core, and a fresh network (the shared
machine_speed workload) has none. That would explain why Train and PSA cost 2.4x more reference steps on an
Intel host than on an AMD one (issue 37); it has not been measured on an Intel host yet (`bench denormals`).

Two remedies, both used:
  * `scrub` sets the subnormal entries of a model's weights (and an optimiser's moments) to zero, at load and
    while training. No behaviour changes: a weight of 1e-39 scales its input by nothing measurable.
  * `flush_in_this_thread` sets the CPU's flush-to-zero and denormals-are-zero modes on the calling thread, so
    its arithmetic neither reads nor makes subnormals. The mode is per thread, and torch's OpenMP team copies
    it from the thread that created it, when it is created: call it first thing in a worker thread, before that
    thread's first torch operation (later, only the calling thread's share of the work is flushed).
"""
from __future__ import annotations

import torch


def flush_in_this_thread() -> bool:
    """Flush-to-zero and denormals-are-zero on this thread (and the OpenMP team it creates from now on).
    False where the CPU has no such mode (then nothing changed)."""
    return bool(torch.set_flush_denormal(True))


SCRUBBED = (torch.float32, torch.float64)  # half precision's 'tiny' (6e-5 in float16) is a real value, not noise


# (exponent bits, mantissa bits) of each scrubbed dtype, and the integer type of its width
_BITS = {torch.float32: (torch.int32, 0x7F800000, 0x007FFFFF),
         torch.float64: (torch.int64, 0x7FF0000000000000, 0x000FFFFFFFFFFFFF)}


def _subnormal(t: torch.Tensor) -> torch.Tensor:
    """Where t is subnormal, read from its bits: a zero exponent and a mantissa that is not. Float comparisons
    would not do: on a thread with denormals-are-zero (the add-on's workers) a subnormal compares equal to 0."""
    int_type, exponent, mantissa = _BITS[t.dtype]
    bits = t.view(int_type)
    return ((bits & exponent) == 0) & ((bits & mantissa) != 0)


def count(tensors) -> int:
    """How many subnormal entries the float32 and float64 tensors hold."""
    return sum(int(_subnormal(t.detach()).sum()) for t in tensors if t.dtype in SCRUBBED)


def module_tensors(module) -> list:
    """A module's parameters and floating-point buffers."""
    return [*module.parameters(), *(b for b in module.buffers() if b.is_floating_point())]


@torch.no_grad()
def scrub(tensors) -> int:
    """Set the subnormal entries of the float32 and float64 tensors to zero, in place; how many there were."""
    total = 0
    for t in tensors:
        if t.dtype not in SCRUBBED:
            continue
        mask = _subnormal(t.detach())
        n = int(mask.sum())
        if n:
            t.detach().masked_fill_(mask, 0.0)
            total += n
    return total


def scrub_module(module) -> int:
    """`scrub` of a module's parameters and floating-point buffers."""
    return scrub(module_tensors(module))
