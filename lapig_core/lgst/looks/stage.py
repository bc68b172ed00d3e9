"""A look stage: a differentiable image operation with its parameters (theta for PSA) kept as tensors.

Each stage holds named parameters (plain tensors; the backend makes them leaf tensors with gradients),
the typical size of each (for PSA's style-retention distance: a colour moves on a 0..1 scale, a
sharpness on a scale of tens), and the function that applies it: apply(x, params, surface) -> x.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import torch


@dataclass
class Stage:
    look: str                                  # the look's name in the catalog
    role: str                                  # medium / palette / mood / texture
    fn: Callable                               # fn(x, params: dict, surface) -> x in [0,1]
    params: dict[str, torch.Tensor] = field(default_factory=dict)
    scales: dict[str, float] = field(default_factory=dict)
    note: str = ""                             # e.g. which colours it uses

    def __call__(self, x: torch.Tensor, surface: torch.Tensor) -> torch.Tensor:
        return self.fn(x, self.params, surface).clamp(0, 1)

    def tensors(self) -> list[tuple[str, torch.Tensor, float]]:
        return [(k, v, self.scales.get(k, 1.0)) for k, v in self.params.items()]

    def label(self) -> str:
        return f"{self.look}({self.note})" if self.note else self.look


def tensor(value) -> torch.Tensor:
    return torch.as_tensor(value, dtype=torch.float32).clone()
