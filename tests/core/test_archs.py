"""Tests for lapig_core.archs: CompenNeSt and PCNet."""

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric.archs import ARCHS, CompenNeSt, PCNet, build, count_parameters, describe
from lapig.lapig_core.photometric.losses import compensation_saturation_loss


def _imgs(b=2, h=32, w=32, seed=0):
    g = torch.Generator().manual_seed(seed)
    return torch.rand(b, 3, h, w, generator=g), torch.rand(b, 3, h, w, generator=g)


@pytest.fixture(scope="module")
def cnet():
    torch.manual_seed(0)
    return CompenNeSt().eval()


@pytest.fixture(scope="module")
def pnet():
    torch.manual_seed(0)
    return PCNet().eval()


# -- parameters and naming ------------------------------------------------------

def test_parameter_counts():
    assert count_parameters(CompenNeSt()) == 805_559
    assert count_parameters(PCNet()) == 1_231_767


def test_describe_and_registry(cnet, pnet):
    assert CompenNeSt.ARCH_NAME == "CompenNeSt" and PCNet.ARCH_NAME == "PCNet"
    assert describe(cnet) == cnet.describe() == "CompenNeSt (805,559 parameters)"
    assert "1,231,767" in describe(pnet)
    assert set(ARCHS) == {"CompenNeSt", "PCNet"}
    assert isinstance(build("PCNet"), PCNet)
    with pytest.raises(ValueError):
        build("nope")


def test_trainable_only_count():
    net = CompenNeSt()
    for p in net.conv6.parameters():
        p.requires_grad_(False)
    assert count_parameters(net, trainable_only=True) == 805_559 - (32 * 3 * 9 + 3)


# -- CompenNeSt -----------------------------------------------------------------

@pytest.mark.parametrize("h,w", [(32, 32), (36, 44)])
def test_compennest_shapes_and_range(cnet, h, w):
    x, s = _imgs(2, h, w)
    with torch.no_grad():
        out, raw = cnet(x, s, return_raw=True)
        out_b = cnet(x, s[:1])  # one surface broadcast over the batch
    assert out.shape == raw.shape == out_b.shape == (2, 3, h, w)
    assert out.min() >= 0 and out.max() <= 1
    torch.testing.assert_close(out, raw.clamp(0, 1))
    # raw really is pre-clamp (random init puts it outside [0, 1]).
    assert raw.min() < 0 or raw.max() > 1


def test_compennest_siamese_subtraction(cnet):
    # With x == s every surface-subtracted feature is zero: output is a pure
    # function of the decoder biases, identical for any image.
    x, _ = _imgs(2)
    with torch.no_grad():
        a, b = cnet(x, x), cnet(x.flip(0), x.flip(0))
    torch.testing.assert_close(a, b)
    torch.testing.assert_close(a[0], a[1])


def test_compennest_deterministic():
    x, s = _imgs()
    outs = []
    for _ in range(2):
        torch.manual_seed(123)
        with torch.no_grad():
            outs.append(CompenNeSt()(x, s))
    assert torch.equal(outs[0], outs[1])


def test_compennest_cache_matches_uncached():
    torch.manual_seed(1)
    net = CompenNeSt().eval()
    x, s = _imgs(2, 32, 32)
    s1 = s[:1]
    with torch.no_grad():
        ref = net(x, s1)
        net.cache_surface(s1)
        torch.testing.assert_close(net(x, s1), ref)
        torch.testing.assert_close(net(x), ref)  # s=None uses the cache
        torch.testing.assert_close(net(x, s1.clone()), ref)  # equal data, other tensor
        other = net(x, s[1:])  # a different surface must not use the cache
        net.clear_surface_cache()
        torch.testing.assert_close(other, net(x, s[1:]))
        with pytest.raises(ValueError):
            net(x)


def test_compennest_cache_invalidated_by_weight_update():
    torch.manual_seed(2)
    net = CompenNeSt().eval()
    x, s = _imgs(1)
    net.cache_surface(s)
    with torch.no_grad():
        net.conv1.weight.mul_(0.5)  # in-place, like optimizer.step()
        cached = net(x, s)
        net.clear_surface_cache()
        fresh = net(x, s)
    torch.testing.assert_close(cached, fresh)


def test_compennest_gradients_with_cache():
    torch.manual_seed(3)
    net = CompenNeSt()
    x, s = _imgs(2)

    def grads(use_cache):
        net.zero_grad()
        net.clear_surface_cache()
        if use_cache:
            net.cache_surface(s)
        xg = x.clone().requires_grad_(True)
        net(xg, s).square().mean().backward()
        return xg.grad, {n: p.grad.clone() for n, p in net.named_parameters()}

    # Training: the cache is bypassed so gradients are exact (s path included).
    net.train()
    gx0, gp0 = grads(False)
    gx1, gp1 = grads(True)
    torch.testing.assert_close(gx0, gx1)
    for n in gp0:
        torch.testing.assert_close(gp0[n], gp1[n], msg=n)

    # Inference with grad (e.g. optimising x): cache used, x and params still get grad.
    net.eval()
    gx2, gp2 = grads(True)
    assert gx2.abs().sum() > 0
    for n in ("conv1.weight", "s1_a.weight", "conv4.weight", "conv6.weight"):
        assert gp2[n].abs().sum() > 0, n
    net.clear_surface_cache()


def test_saturation_loss_reaches_network_through_raw():
    torch.manual_seed(4)
    net = CompenNeSt()
    x, s = _imgs(1)
    out, raw = net(x, s, return_raw=True)
    raw.retain_grad()
    loss = compensation_saturation_loss(raw)
    assert loss > 0
    loss.backward()
    assert raw.grad.abs().sum() > 0
    assert net.conv6.weight.grad.abs().sum() > 0 and net.conv1.weight.grad.abs().sum() > 0


# -- PCNet ----------------------------------------------------------------------

@pytest.mark.parametrize("h,w", [(32, 32), (36, 44)])
def test_pcnet_shapes_and_default_range(pnet, h, w):
    x, s = _imgs(2, h, w)
    with torch.no_grad():
        y = pnet(x, s)
        y_b = pnet(x, s[:1])
    assert y.shape == y_b.shape == (2, 3, h, w)
    assert y.min() >= 0 and y.max() <= 1
    torch.testing.assert_close(y_b[0], y[0])  # sample 0 uses s[0] either way


def test_pcnet_per_pixel_bounds(pnet):
    x, s = _imgs(2)
    g = torch.Generator().manual_seed(9)
    i_min = 0.3 * torch.rand(1, 3, 32, 32, generator=g)
    i_max = i_min + 0.2 + 0.3 * torch.rand(1, 3, 32, 32, generator=g)
    with torch.no_grad():
        free = pnet(x, s)
        y = pnet(x, s, i_min, i_max)
        y_scalar = pnet(x, s, 0.25, 0.5)
    assert (y >= i_min).all() and (y <= i_max).all()
    torch.testing.assert_close(y, torch.minimum(torch.maximum(free, i_min), i_max))
    assert y_scalar.min() >= 0.25 and y_scalar.max() <= 0.5


def test_pcnet_uses_surface_and_gradients():
    torch.manual_seed(5)
    net = PCNet()
    x, s = _imgs(2)
    xg = x.clone().requires_grad_(True)
    y = net(xg, s)
    assert not torch.allclose(y, net(x, s.flip(0)))
    y.mean().backward()
    assert xg.grad.abs().sum() > 0
    for name in ("conv1.weight", "sconv1.weight", "skip1.weight", "skip2.weight", "res_a.weight"):
        assert getattr(net, name.split(".")[0]).weight.grad is not None, name


def test_pcnet_deterministic():
    x, s = _imgs()
    outs = []
    for _ in range(2):
        torch.manual_seed(7)
        with torch.no_grad():
            outs.append(PCNet()(x, s))
    assert torch.equal(outs[0], outs[1])


def test_compennest_graph_free_forward_equals_the_graph_one():
    """Without a graph, forward() writes each step over its input (speed at native resolution): the
    same numbers as the graph's forward, raw output included, and the inputs and cache untouched."""
    torch.manual_seed(2)
    net = CompenNeSt().eval()
    x, s = _imgs(2, 48, 64, seed=3)
    x_before, s_before = x.clone(), s.clone()
    out_graph, raw_graph = net(x, s, return_raw=True)
    with torch.no_grad():
        out, raw = net(x, s, return_raw=True)
        net.cache_surface(s[:1])
        cached = [f.clone() for f in net._cache["feats"]]
        out_cached = net(x)
        net(x)  # twice: the cached features must not have been written over
        for f, kept in zip(net._cache["feats"], cached):
            assert torch.equal(f, kept)
    assert torch.equal(out, out_graph.detach()) and torch.equal(raw, raw_graph.detach())
    torch.testing.assert_close(out_cached, net(x, s[:1].expand_as(x)).detach())
    assert torch.equal(x, x_before) and torch.equal(s, s_before)
    assert raw.min() < 0 and out.min() >= 0 and out.max() <= 1  # raw is the pre-ReLU output, not the clamped one
    with torch.no_grad():  # a batch of surfaces for one image still broadcasts, as the graph's forward does
        many = net(x[:1], s)
    torch.testing.assert_close(many, net(x[:1].expand_as(s), s).detach())


def test_the_surface_cache_follows_the_weights_device():
    """SurfaceModels caches the surface when it is built, before its .to(device): the learned compensator's weights
    may be on a GPU already (train_models on CUDA) while the surface is still on the CPU. The meta device stands
    in for the GPU here."""
    net = CompenNeSt().to("meta")
    net.cache_surface(torch.rand(1, 3, 32, 32))
    assert all(f.device.type == "meta" for f in net._cache["feats"])
