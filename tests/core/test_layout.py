# SPDX-License-Identifier: GPL-3.0-or-later
"""Channels-last activations on the CPU (lapig_core/photometric/archs/layout): the networks give what they gave in
NCHW, forward and backward, and hand back NCHW-contiguous tensors. The truth is a float64 run of the same network,
not the float32 NCHW run: oneDNN's kernels differ by CPU (AVX2, AVX-512), and neither layout's float32 rounding is
the reference. .ci/run runs this file a second time with ONEDNN_MAX_CPU_ISA=AVX2, as on a CPU without AVX-512."""
import copy

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
        (y * torch.linspace(0, 1, y.numel(), dtype=y.dtype).view_as(y)).sum().backward()
        return y.detach(), x.grad, [p.grad.clone() for p in net.parameters()]
    with torch.no_grad():
        return net(x, s), None, []


def _inputs(dtype=torch.float32):
    g = torch.Generator().manual_seed(1)
    x, s = torch.rand(4, 3, 32, 48, generator=g), torch.rand(1, 3, 32, 48, generator=g)  # one surface broadcast
    return x.to(dtype), s.to(dtype)


@pytest.mark.parametrize("arch", [CompenNeSt, PCNet])
def test_in_float64_channels_last_gives_the_nchw_figures_exactly(arch, restore_layout):
    """The layout's own correctness, on any CPU: float64 runs torch's native kernels (not oneDNN), where the two
    layouts differ only by the order of a few sums."""
    torch.manual_seed(0)
    net = arch().train().double()
    x, s = _inputs(torch.float64)
    inside = []
    net.conv4.register_forward_hook(lambda m, i, o: inside.append(o.is_contiguous(memory_format=torch.channels_last)))
    before, now = _run(net, x, s, "nchw"), _run(net, x, s, "channels_last")
    assert inside == [False, True]  # the work between is channels-last
    assert now[0].is_contiguous() and now[0].shape == before[0].shape  # the callers' tensors as before
    torch.testing.assert_close(now[0], before[0], rtol=0, atol=1e-12)
    torch.testing.assert_close(now[1], before[1], rtol=1e-10, atol=1e-14)
    for a, b in zip(now[2], before[2]):
        assert float((a - b).norm()) < 1e-10 * max(float(b.norm()), 1.0)


# Float32 against a float64 reference of the same network, in both layouts. Tolerances, from measured figures:
# - the gradient into the image (PSA's): the networks are piecewise linear, and a pre-activation within float
#   rounding of 0 can fall on the other side of a ReLU's kink. One such flip (1 of PCNet's 98,304 conv4 units, with
#   oneDNN's AVX2 kernels in NCHW: ONEDNN_MAX_CPU_ISA=AVX2 on an AVX-512 machine, or a CPU without AVX-512) moved the
#   whole image gradient by 4.9e-4 of its norm; without a flip the error is 1e-7 to 4e-7. A wrong stride or layout
#   moves it by the order of 1. Allowed: 5e-3 (ten such flips).
# - the weights' gradients (Train's): sums over every pixel, whose float32 error scales with the whole gradient, not
#   with each parameter's own (CompenNeSt's s1_c.bias sums to exactly 0 in float64 and to 2.5e-3 in float32, beside
#   parameters whose gradients have norms in the thousands). Measured at most 2.5e-7 of the whole gradient's norm
#   without a flip, 1.6e-5 with the one above; allowed 2e-4 (ten flips).
IMAGE_GRADIENT_RTOL, WEIGHT_GRADIENT_RTOL = 5e-3, 2e-4


@pytest.mark.parametrize("layout_name", ["channels_last", "nchw"])
@pytest.mark.parametrize("arch", [CompenNeSt, PCNet])
def test_in_float32_each_layout_gives_the_float64_figures(arch, layout_name, restore_layout):
    torch.manual_seed(0)
    net = arch().train()
    reference = _run(copy.deepcopy(net).double(), *_inputs(torch.float64), "nchw")
    y, grad_x, grad_w = _run(net, *_inputs(), layout_name)
    torch.testing.assert_close(y.double(), reference[0], rtol=0, atol=1e-5)
    image_error = float((grad_x.double() - reference[1]).norm() / reference[1].norm())
    assert image_error < IMAGE_GRADIENT_RTOL, image_error
    whole = float(torch.cat([g.flatten() for g in reference[2]]).norm())
    worst = max(float((a.double() - b).norm()) for a, b in zip(grad_w, reference[2]))
    assert worst < WEIGHT_GRADIENT_RTOL * whole, (worst, whole)
    net.eval()
    ref_eval = _run(copy.deepcopy(net).double(), *_inputs(torch.float64), "nchw", grad=False)[0]
    torch.testing.assert_close(_run(net, *_inputs(), layout_name, grad=False)[0].double(), ref_eval, rtol=0, atol=1e-5)


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
