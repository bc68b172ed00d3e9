"""Adam as torch.optim.Adam computes it on the CPU (bias-corrected, L2 weight decay added to the gradient), without
importing torch.optim.

Why not torch.optim: a process's first torch.optim optimiser imports torch._dynamo, sympy and torch.distributed
(about 1.3 s), holding Python's GIL for up to 170 ms at a time, which froze Blender's UI while a job or the
warm-up ran on a worker thread (BENCHMARKS, issue 28). Our loops use none of its compile, foreach or fused
machinery. Steps match torch.optim.Adam's single-tensor path to the last bit (tests/core/test_adam.py).

The learning rate is a group's "lr", which callers set before a step (the schedules are a line each).
"""
from __future__ import annotations

import torch


class Adam:
    def __init__(self, params, lr: float = 1e-3, betas: tuple = (0.9, 0.999), eps: float = 1e-8,
                 weight_decay: float = 0.0):
        """params: tensors, or groups as torch.optim takes them ([{"params": [...], "lr": ...}, ...])."""
        params = list(params)
        if not params:
            raise ValueError("Adam was given no parameters")
        groups = params if isinstance(params[0], dict) else [{"params": params}]
        defaults = {"lr": lr, "betas": betas, "eps": eps, "weight_decay": weight_decay}
        self.param_groups = [{**defaults, **group, "params": list(group["params"])} for group in groups]
        self.state: dict = {}

    def zero_grad(self, set_to_none: bool = True) -> None:
        for group in self.param_groups:
            for p in group["params"]:
                if p.grad is None:
                    continue
                if set_to_none:
                    p.grad = None
                else:
                    p.grad.detach_().zero_()

    def moments(self) -> list:
        """The first and second moments of every parameter stepped so far."""
        return [t for state in self.state.values() for t in (state["exp_avg"], state["exp_avg_sq"])]

    def reset_state(self) -> None:
        """Forget the moments (after the weights were set back, e.g. from a NaN)."""
        self.state.clear()

    @torch.no_grad()
    def step(self) -> None:
        for group in self.param_groups:
            lr, (beta1, beta2), eps, decay = group["lr"], group["betas"], group["eps"], group["weight_decay"]
            for p in group["params"]:
                if p.grad is None:
                    continue
                grad = p.grad
                state = self.state.get(p)
                if state is None:
                    state = self.state[p] = {"step": 0, "exp_avg": torch.zeros_like(p),
                                             "exp_avg_sq": torch.zeros_like(p)}
                state["step"] += 1
                if decay:
                    grad = grad.add(p, alpha=decay)
                exp_avg, exp_avg_sq = state["exp_avg"], state["exp_avg_sq"]
                exp_avg.lerp_(grad, 1 - beta1)
                exp_avg_sq.mul_(beta2).addcmul_(grad, grad, value=1 - beta2)
                step = float(state["step"])
                bias_correction1 = 1 - beta1 ** step
                bias_correction2_sqrt = (1 - beta2 ** step) ** 0.5
                denom = (exp_avg_sq.sqrt() / bias_correction2_sqrt).add_(eps)
                p.addcdiv_(exp_avg, denom, value=-lr / bias_correction1)
