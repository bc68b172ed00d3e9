# SPDX-License-Identifier: GPL-3.0-or-later
"""Issue 28's core pieces: the classical model as PSA's differentiable simulator, and the surface path of the
fine-tune run once per batch of one setup (the same gradient as eight copies)."""
import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric import checkpoints  # noqa: E402
from lapig.lapig_core.photometric.choice import CLASSICAL, LEARNED, CompensatorChoice  # noqa: E402
from lapig.lapig_core.photometric.first_look import after_train_note  # noqa: E402
from lapig.lapig_core.photometric.classical_compensator import ClassicalCompensator, ClassicalSimulator  # noqa: E402
from lapig.lapig_core.photometric.training_data import PairSet, SurfaceTensors  # noqa: E402

from test_classical import _patterns, _truth  # noqa: E402

pytestmark = pytest.mark.torch


def _nchw(a):
    return torch.from_numpy(np.ascontiguousarray(np.asarray(a, np.float32).transpose(0, 3, 1, 2)))


def test_the_classical_simulator_is_the_models_forward_direction_and_differentiable():
    model = _truth()
    prj = _patterns(3, seed=4)
    sim = ClassicalSimulator(model)
    out = sim(_nchw(prj))
    np.testing.assert_allclose(out.numpy().transpose(0, 2, 3, 1), model.simulate(prj), atol=2e-5)
    # bounds as PCNet's: the capture under black and white projection
    lo, hi = torch.full_like(out, 0.3), torch.full_like(out, 0.6)
    bounded = sim(_nchw(prj), None, lo, hi)
    assert float(bounded.min()) >= 0.3 - 1e-6 and float(bounded.max()) <= 0.6 + 1e-6
    # PSA's gradient reaches the target through compensation and simulation
    target = torch.full((1, 3, 32, 40), 0.4, requires_grad=True)
    loss = ((sim(ClassicalCompensator(model)(target)) - 0.5) ** 2).mean()
    loss.backward()
    assert torch.isfinite(target.grad).all() and float(target.grad.abs().sum()) > 0
    with pytest.raises(ValueError, match="classical simulator is 32x40"):
        sim(torch.zeros(1, 3, 16, 16))


def test_compensate_then_simulate_recovers_a_reachable_target():
    model = _truth()
    target = model.simulate(_patterns(1, seed=9, lo=0.3, hi=0.7))
    t = _nchw(target)
    back = ClassicalSimulator(model)(ClassicalCompensator(model)(t))
    np.testing.assert_allclose(back.numpy(), t.numpy(), atol=2e-3)


@pytest.mark.parametrize("arch", ["CompenNeSt", "PCNet"])
def test_one_surface_per_batch_gives_the_gradient_of_eight_copies(arch):
    g = torch.Generator().manual_seed(0)
    x, y = torch.rand(8, 3, 16, 16, generator=g), torch.rand(8, 3, 16, 16, generator=g)
    s = torch.rand(1, 3, 16, 16, generator=g)
    pairs = PairSet(x, y, torch.zeros(8, dtype=torch.long), [SurfaceTensors(s, s * 0, s * 0 + 1)], "compensation")
    idx = torch.arange(8)
    xb, sb, yb = pairs.batch(idx)
    assert sb.shape[0] == 1  # one setup: its surface once

    def grads(surface):
        net = checkpoints.new_model(arch, 0)
        out = net(xb, surface) if arch == "CompenNeSt" else net(xb, surface, 0.0, 1.0)
        (out - yb).abs().mean().backward()
        return [p.grad.clone() for p in net.parameters()]

    once, copies = grads(sb), grads(sb.expand(8, -1, -1, -1).contiguous())
    for a, b in zip(once, copies):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6)
    # two setups in one set: each sample keeps its own surface
    two = PairSet(x, y, torch.tensor([0, 1] * 4), [SurfaceTensors(s, s, s), SurfaceTensors(s * 0.5, s, s)],
                  "compensation")
    assert two.batch(idx)[1].shape[0] == 8


@pytest.mark.parametrize("chosen, learned, classical, said", [
    (LEARNED, 31.5, 30.0, "the networks are 1.50 dB ahead of the first look: Generate again to use them"),
    (CLASSICAL, 29.0, 30.0, "the first look's classical model stays the compensator (1.00 dB ahead of CompenNeSt)"),
    (CLASSICAL, 30.5, 30.0, "the first look's classical model stays the compensator (CompenNeSt only 0.50 dB ahead, "
                            "less than the lead it needs)"),
    (LEARNED, None, None, ""),  # nothing measured: nothing to say
])
def test_after_train_says_which_compensator_the_measurement_chose(chosen, learned, classical, said):
    assert after_train_note(CompensatorChoice(chosen, learned, classical, 4)) == said
