# SPDX-License-Identifier: GPL-3.0-or-later
"""The optional InstructPix2Pix LGST backend, offline, on a tiny random pipeline built from configs.

The tiny pipeline is saved to a folder and loaded back through the backend's own loading code, the path
users run with real weights. Tests that need diffusers skip when it is not installed (it is optional:
requirements-ip2p.txt).
"""
import importlib.util
import subprocess
import sys
import warnings

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst import BACKENDS, LGSTUnavailable, get_backend
from lapig.lapig_core.lgst import ip2p_backend as ip2p

PROMPT = "Make it a Claymation"
HAS_DIFFUSERS = all(importlib.util.find_spec(m) is not None for m in ("diffusers", "transformers"))
needs_diffusers = pytest.mark.skipif(not HAS_DIFFUSERS, reason="diffusers/transformers not installed "
                                     "(optional: pip install -r requirements-ip2p.txt)")


def _byte_symbols():
    """The 256 printable symbols byte-level BPE uses for bytes (the GPT-2/CLIP byte-to-unicode table)."""
    printable = (set(range(ord("!"), ord("~") + 1)) | set(range(ord("\xa1"), ord("\xac") + 1))
                 | set(range(ord("\xae"), ord("\xff") + 1)))
    out, extra = [], 0
    for b in range(256):
        if b in printable:
            out.append(chr(b))
        else:
            out.append(chr(256 + extra))
            extra += 1
    return out


def _tiny_tokenizer():
    """A CLIP tokenizer with a byte-only vocabulary and no merges: any text tokenises, no file needed."""
    from transformers import CLIPTokenizer

    vocab = {"<|startoftext|>": 0, "<|endoftext|>": 1}
    for suffix in ("", "</w>"):
        for sym in _byte_symbols():
            vocab[sym + suffix] = len(vocab)
    return CLIPTokenizer(vocab=vocab, merges=[], model_max_length=77), len(vocab)


@pytest.fixture(scope="session")
def tiny_model(tmp_path_factory):
    """Folder of a tiny random InstructPix2Pix pipeline (UNet with 8 input channels, 4-block VAE)."""
    pytest.importorskip("diffusers")
    pytest.importorskip("transformers")
    from diffusers import (AutoencoderKL, EulerAncestralDiscreteScheduler, StableDiffusionInstructPix2PixPipeline,
                           UNet2DConditionModel)
    from transformers import CLIPTextConfig, CLIPTextModel

    torch.manual_seed(0)
    tokenizer, vocab_size = _tiny_tokenizer()
    text_encoder = CLIPTextModel(CLIPTextConfig(
        vocab_size=vocab_size, hidden_size=16, intermediate_size=32, num_attention_heads=2, num_hidden_layers=1,
        max_position_embeddings=77, projection_dim=16, bos_token_id=0, eos_token_id=1, pad_token_id=1))
    unet = UNet2DConditionModel(
        sample_size=8, in_channels=8, out_channels=4, block_out_channels=(8, 16), layers_per_block=1,
        down_block_types=("CrossAttnDownBlock2D", "DownBlock2D"), up_block_types=("UpBlock2D", "CrossAttnUpBlock2D"),
        cross_attention_dim=16, attention_head_dim=4, norm_num_groups=4)
    # four blocks -> downscale 8, as Stable Diffusion's VAE
    vae = AutoencoderKL(
        in_channels=3, out_channels=3, block_out_channels=(4, 4, 8, 8), layers_per_block=1,
        down_block_types=("DownEncoderBlock2D",) * 4, up_block_types=("UpDecoderBlock2D",) * 4,
        latent_channels=4, norm_num_groups=4, sample_size=64)
    scheduler = EulerAncestralDiscreteScheduler(beta_start=0.00085, beta_end=0.012, beta_schedule="scaled_linear")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pipe = StableDiffusionInstructPix2PixPipeline(
            vae=vae, text_encoder=text_encoder, tokenizer=tokenizer, unet=unet, scheduler=scheduler,
            safety_checker=None, feature_extractor=None, requires_safety_checker=False)
    folder = tmp_path_factory.mktemp("tiny_ip2p")
    pipe.save_pretrained(folder)
    return str(folder)


def _surface(h=64, w=64, seed=0):
    g = torch.Generator().manual_seed(seed)
    return torch.rand(1, 3, h, w, generator=g)


def _backend(model, **kw):
    kw = {"size": 64, "steps": 2, "psa_steps": 2, **kw}
    return get_backend("instruct-pix2pix", model=model, **kw)


# -- registry and availability (no diffusers needed) --------------------------------------------
def test_registered_and_import_stays_light():
    assert BACKENDS["instruct-pix2pix"] is ip2p.InstructPix2PixBackend
    code = ("import sys, lapig_core.lgst as L; L.available_backends(); "
            "print(any(m.split('.')[0] in ('diffusers', 'transformers') for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == "False", "importing lapig_core.lgst must not import diffusers/transformers"


def test_missing_folder_unavailable_with_clear_message(tmp_path):
    missing = tmp_path / "no_weights_here"
    ok, why = ip2p.InstructPix2PixBackend.availability(model=str(missing))
    assert ok is False and "styletransfer" in why
    backend = get_backend("instruct-pix2pix", model=str(missing))
    assert backend.model == str(missing)
    with pytest.raises(LGSTUnavailable) as err:
        backend.prepare(_surface(), PROMPT)
    assert "styletransfer" in str(err.value)


@needs_diffusers
def test_missing_weights_say_where_and_how_to_download_them(tmp_path):
    missing = tmp_path / "no_weights_here"
    ok, why = ip2p.InstructPix2PixBackend.availability(model=str(missing))
    assert why.startswith(f"InstructPix2Pix weights not found at {missing}")
    with pytest.raises(LGSTUnavailable, match="hf download") as err:
        get_backend("instruct-pix2pix", model=str(missing)).prepare(_surface(), PROMPT)
    assert f"InstructPix2Pix weights not found at {missing}" in str(err.value)


def test_missing_packages_are_named_before_the_weights(tmp_path, monkeypatch):
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "diffusers" else find_spec(name, *a))
    ok, why = ip2p.InstructPix2PixBackend.availability(model=str(tmp_path))
    assert ok is False and why.startswith("InstructPix2Pix needs the 'diffusers' package")
    with pytest.raises(LGSTUnavailable, match="InstructPix2Pix needs diffusers and transformers"):
        get_backend("instruct-pix2pix", model=str(tmp_path)).prepare(_surface(), PROMPT)


def test_empty_prompt_is_rejected_before_loading(tmp_path):
    backend = get_backend("instruct-pix2pix", model=str(tmp_path / "missing"))
    with pytest.raises(ValueError, match="empty"):
        backend.prepare(_surface(), "   ")


def test_bad_arguments():
    with pytest.raises(ValueError):
        get_backend("instruct-pix2pix", steps=0)
    with pytest.raises(ValueError):
        get_backend("instruct-pix2pix", size=4)
    assert ip2p.work_shape(600, 800, 256, 8) == (192, 256)
    assert ip2p.work_shape(64, 64, 64, 8) == (64, 64)


@needs_diffusers
def test_uncached_hub_id_fails_offline_without_download(monkeypatch):
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")  # belt and braces: local_files_only already forbids it
    backend = get_backend("instruct-pix2pix", model="lapig-tests/no-such-ip2p-model")
    ok, why = ip2p.model_status(backend.model)
    assert not ok and "Hugging Face cache" in why
    with pytest.raises(LGSTUnavailable, match="weights not found at 'lapig-tests/no-such-ip2p-model'"):
        backend.prepare(_surface(), PROMPT)


# -- the tiny pipeline, loaded through the backend ----------------------------------------------
def test_available_and_describe(tiny_model):
    ok, why = ip2p.InstructPix2PixBackend.availability(model=tiny_model)
    assert ok and tiny_model in why
    backend = _backend(tiny_model)
    backend.prepare(_surface(), PROMPT, seed=3)
    info = backend.describe()
    assert info["backend"] == "instruct-pix2pix" and info["model"] == tiny_model
    assert info["steps"] == 2 and info["guidance"] == 7.5 and info["image_guidance"] == 1.0
    assert info["styles"] == [] and info["effects"] == [] and info["prompt"] == PROMPT
    assert info["dtype"] == "float32" and info["device"] == "cpu"


def test_defaults_follow_the_public_code():
    b = ip2p.InstructPix2PixBackend()
    assert (b.steps, b.guidance, b.image_guidance, b.size, b.psa_steps) == (10, 7.5, 1.0, 256, 4)
    assert not b.allow_download


def test_stylize_shape_range_and_seed(tiny_model):
    backend = _backend(tiny_model)
    surface = _surface()
    a = backend.stylize(surface, PROMPT, seed=1)
    b = backend.stylize(surface, PROMPT, seed=1)
    c = backend.stylize(surface, PROMPT, seed=2)
    assert a.shape == surface.shape and a.dtype == torch.float32
    assert float(a.min()) >= 0.0 and float(a.max()) <= 1.0 and torch.isfinite(a).all()
    assert torch.equal(a, b)
    assert not torch.equal(a, c)
    # a surface whose size is not the working size comes back at its own size
    odd = backend.stylize(_surface(40, 72), PROMPT, seed=1)
    assert odd.shape == (1, 3, 40, 72)


def test_forward_is_differentiable_and_deterministic(tiny_model):
    backend = _backend(tiny_model)
    surface = _surface()
    backend.prepare(surface, PROMPT, seed=0)
    (theta,) = backend.parameters()
    assert theta.is_leaf and theta.requires_grad and theta.dtype == torch.float32
    out = backend.forward()
    assert out.shape == surface.shape and float(out.detach().min()) >= 0 and float(out.detach().max()) <= 1
    out.mean().backward()
    assert theta.grad is not None and torch.isfinite(theta.grad).all() and theta.grad.abs().sum() > 0
    assert all(p.grad is None for p in backend.pipe.unet.parameters())  # the weights stay frozen
    with torch.no_grad():
        assert torch.equal(backend.forward(), backend.forward())  # noise fixed in prepare
        assert float(backend.theta_distance()) == 0.0
        saved = backend.state()
        theta.add_(0.5)
        assert float(backend.theta_distance()) > 0
        backend.load_state(saved)
        assert torch.equal(theta, backend.anchor()[0])


@pytest.mark.parametrize("image_guidance", [1.0, 1.5])
def test_sampler_matches_diffusers_ddim(tiny_model, image_guidance):
    """forward() is the pipeline with DDIM ('trailing', eta 0) run from the same noise, with gradients.

    4 steps (the default) divide the 1000 training steps; for other counts diffusers' DDIM steps to
    t - 1000 // n instead of the next scheduled timestep, a one-step difference that forward() avoids.
    """
    from diffusers import DDIMScheduler, StableDiffusionInstructPix2PixPipeline

    backend = _backend(tiny_model, image_guidance=image_guidance, psa_steps=4)
    backend.prepare(_surface(seed=4), PROMPT, seed=5)
    with torch.no_grad():
        ours = backend.forward()
    pipe = backend.pipe
    ddim = DDIMScheduler.from_config(pipe.scheduler.config, timestep_spacing="trailing", set_alpha_to_one=True,
                                     clip_sample=False)
    ref = StableDiffusionInstructPix2PixPipeline(**{**pipe.components, "scheduler": ddim},
                                                 requires_safety_checker=False)
    ref.set_progress_bar_config(disable=True)
    theirs = ref(image=backend._image, prompt_embeds=backend.parameters()[0].detach(),
                 negative_prompt_embeds=backend._uncond, num_inference_steps=4, guidance_scale=7.5,
                 image_guidance_scale=image_guidance, latents=backend._noise, output_type="pt").images
    assert torch.allclose(ours, theirs, atol=1e-5)


def test_checkpointing_gives_the_same_gradient(tiny_model):
    grads = []
    for checkpointing in (False, True):
        backend = _backend(tiny_model, checkpointing=checkpointing)
        backend.prepare(_surface(), PROMPT, seed=0)
        backend.forward().square().mean().backward()
        grads.append(backend.parameters()[0].grad)
    assert torch.allclose(grads[0], grads[1], rtol=1e-4, atol=1e-8)


def test_runs_inside_psa(tiny_model):
    from lapig.lapig_core.psa import adaptation as psa
    from lapig.lapig_core.photometric.checkpoints import new_model
    from lapig.lapig_core.photometric.surface_models import SurfaceModels

    torch.manual_seed(0)
    s = torch.rand(1, 3, 32, 32) * 0.5 + 0.25
    models = SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), s, s * 0.1, s * 0.9)
    backend = _backend(tiny_model, size=32)
    backend.prepare(s, PROMPT, seed=0)
    result = psa.run_psa(backend, models, psa.PSASettings(max_iterations=2, stop_ratio=0))
    assert result.iterations == 2 and result.target.shape == s.shape
    assert all(torch.isfinite(torch.tensor(h["total"])) for h in result.history)
    from lapig.tools.research.psa_resample import run_resample

    resampled = run_resample(backend, models, psa.PSASettings(max_iterations=1, stop_ratio=0))
    assert resampled.target.shape == s.shape
