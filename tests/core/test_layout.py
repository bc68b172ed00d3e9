# SPDX-License-Identifier: GPL-3.0-or-later
"""Channels-last activations on the CPU (lapig_core/photometric/archs/layout): the networks give what they gave in
NCHW, to float rounding, forward and backward, and hand back NCHW-contiguous tensors."""
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric.archs import CompenNeSt, PCNet, layout  # noqa: E402
from lapig.tools.bench import bench_layout  # noqa: E402

pytestmark = pytest.mark.torch


@pytest.fixture
def restore_layout():
    yield
    bench_layout.use_layout("channels_last")


def _run(net, x, s, layout_name, grad=True):
    bench_layout.use_layout(layout_name)
    x = x.clone().requires_grad_(grad)
    net.zero_grad(set_to_none=True)
    if grad:
        y = net(x, s)
        (y * torch.linspace(0, 1, y.numel()).view_as(y)).sum().backward()
        return y.detach(), x.grad, [p.grad.clone() for p in net.parameters()]
    with torch.no_grad():
        return net(x, s), None, []


@pytest.mark.parametrize("arch", [CompenNeSt, PCNet])
def test_channels_last_gives_the_nchw_figures_forward_and_backward(arch, restore_layout):
    torch.manual_seed(0)
    net = arch().train()
    g = torch.Generator().manual_seed(1)
    x, s = torch.rand(4, 3, 32, 48, generator=g), torch.rand(1, 3, 32, 48, generator=g)  # one surface broadcast
    inside = []
    net.conv4.register_forward_hook(lambda m, i, o: inside.append(o.is_contiguous(memory_format=torch.channels_last)))
    before, now = _run(net, x, s, "nchw"), _run(net, x, s, "channels_last")
    assert inside == [False, True]  # the work between is channels-last
    assert now[0].is_contiguous() and now[0].shape == before[0].shape  # the callers' tensors as before
    torch.testing.assert_close(now[0], before[0], rtol=0, atol=1e-5)
    torch.testing.assert_close(now[1], before[1], rtol=1e-4, atol=1e-6)  # PSA's gradient into the image
    # Train's gradients of the weights: sums over every pixel, in another order (a bias whose gradient cancels to
    # zero, the siamese encoder's last ones, is float noise in both: measured against 1, not against itself)
    for a, b in zip(now[2], before[2]):
        assert float((a - b).norm()) < 1e-4 * max(float(b.norm()), 1.0)
    net.eval()
    torch.testing.assert_close(_run(net, x, s, "channels_last", grad=False)[0],
                               _run(net, x, s, "nchw", grad=False)[0], rtol=0, atol=1e-5)


def test_only_the_cpus_4d_tensors_change_layout():
    x = torch.rand(2, 3, 8, 8)
    assert layout.into(x).is_contiguous(memory_format=torch.channels_last)
    assert layout.out_of(layout.into(x)).is_contiguous() and torch.equal(layout.out_of(layout.into(x)), x)
    flat = torch.rand(3, 8)
    assert layout.into(flat) is flat and layout.out_of(flat) is flat
    meta = torch.empty(2, 3, 8, 8, device="meta")  # another device keeps NCHW
    assert layout.into(meta) is meta


def test_the_compensation_with_its_cached_surface_is_the_same_in_both_layouts(restore_layout):
    """CompenNeSt's surface cache (inference) made in one layout serves the other: the features are the same."""
    torch.manual_seed(0)
    net = CompenNeSt().eval()
    g = torch.Generator().manual_seed(2)
    x, s = torch.rand(1, 3, 64, 96, generator=g), torch.rand(1, 3, 64, 96, generator=g)
    bench_layout.use_layout("nchw")
    with torch.no_grad():
        reference = net(x, s)
    bench_layout.use_layout("channels_last")
    net.cache_surface(s)
    with torch.no_grad():
        cached = net(x, s)
    torch.testing.assert_close(cached, reference, rtol=0, atol=1e-5)
    assert cached.is_contiguous()


def test_bench_layout_compares_both_layouts_on_one_frame(restore_layout):
    from lapig.lapig_core.capture.dataset import load_capture_set
    from lapig.tools.bench.device_fixture import FIXTURE

    out = bench_layout.time_compensate(load_capture_set(FIXTURE), size=(256, 192))
    assert out["nchw_s"] > 0 and out["channels_last_s"] > 0 and out["ratio"] > 0
    assert out["max_abs_difference"] < 1e-4 and out["frame"] == [256, 192]
