# SPDX-License-Identifier: GPL-3.0-or-later
"""lapig_core.common.adam: the same steps as torch.optim.Adam, without importing torch._dynamo."""
import os
import subprocess
import sys

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.common.adam import Adam  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _net():
    torch.manual_seed(0)
    return torch.nn.Sequential(torch.nn.Conv2d(3, 8, 3, padding=1), torch.nn.ReLU(), torch.nn.Conv2d(8, 3, 1))


@pytest.mark.parametrize("weight_decay", [0.0, 1e-4])
def test_steps_match_torch_optim_adam_bit_for_bit(weight_decay):
    ours, theirs = _net(), _net()
    opt_ours = Adam(ours.parameters(), lr=1e-3, weight_decay=weight_decay)
    opt_theirs = torch.optim.Adam(theirs.parameters(), lr=1e-3, weight_decay=weight_decay)
    gen = torch.Generator().manual_seed(1)
    for k in range(30):
        x = torch.rand(4, 3, 16, 16, generator=gen)
        for net, opt in ((ours, opt_ours), (theirs, opt_theirs)):
            for group in opt.param_groups:  # a schedule, as Train's lr steps set it
                group["lr"] = 1e-3 * (0.2 if k >= 20 else 1.0)
            opt.zero_grad(set_to_none=True)
            (net(x) - x).abs().mean().backward()
            opt.step()
    for a, b in zip(ours.parameters(), theirs.parameters()):
        assert torch.equal(a, b)


def test_groups_keep_their_own_learning_rates_and_params_without_grad_stay():
    a, b, frozen = (torch.ones(3, requires_grad=True) for _ in range(3))
    opt = Adam([{"params": [a], "lr": 0.1}, {"params": [b, frozen], "lr": 0.01}])
    (a.sum() + b.sum()).backward()
    opt.step()
    # Adam's first step moves each weight by its lr (the bias-corrected ratio is 1)
    assert torch.allclose(a, torch.full((3,), 0.9), atol=1e-6)
    assert torch.allclose(b, torch.full((3,), 0.99), atol=1e-6)
    assert torch.equal(frozen, torch.ones(3))
    opt.zero_grad()
    assert a.grad is None and b.grad is None


def test_reset_state_forgets_the_moments():
    w = torch.zeros(2, requires_grad=True)
    opt = Adam([w], lr=0.5)
    w.sum().backward()
    opt.step()
    opt.reset_state()
    assert opt.state == {}


def test_no_parameters_is_a_clear_error():
    with pytest.raises(ValueError, match="no parameters"):
        Adam([])


def test_a_step_imports_no_dynamo():
    """The reason this module exists: torch.optim's first optimiser imports torch._dynamo (and holds the GIL)."""
    code = ("import sys, torch\n"
            "from lapig_core.common.adam import Adam\n"
            "w = torch.zeros(3, requires_grad=True); o = Adam([w]); w.sum().backward(); o.step()\n"
            "print('torch._dynamo' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "False"
