# SPDX-License-Identifier: GPL-3.0-or-later
"""Tiny diffusers pipelines with random weights (about 1 MB), built from configs and saved as a model repository
would hold them: the model manager's tests and `bench diffusion` download them from fake_model_hub, then load and
run them as the real models. kind 'ip2p': StableDiffusionInstructPix2PixPipeline (UNet with 8 input channels);
'img2img': StableDiffusionImg2ImgPipeline (the one-step model's class, 4 input channels). make_tiny_adapter: a tiny
T2I-Adapter for that UNet (its channels, 8 and 16), saved as the depth adapter's repository holds it (config.json and
diffusion_pytorch_model.bin at the root)."""
from __future__ import annotations

import warnings


def _byte_symbols() -> list[str]:
    """The 256 symbols byte-level BPE (GPT-2, CLIP) writes bytes as."""
    keep = set(range(33, 127)) | set(range(161, 173)) | set(range(174, 256))
    out, extra = [], 0
    for b in range(256):
        if b in keep:
            out.append(chr(b))
        else:
            out.append(chr(256 + extra))
            extra += 1
    return out


def tiny_tokenizer():
    """A CLIP tokenizer with a vocabulary of bytes and no merges: every text tokenises; it saves as vocab.json
    and merges.txt like the real one."""
    from transformers import CLIPTokenizer

    vocab = {"<|startoftext|>": 0, "<|endoftext|>": 1}
    for suffix in ("", "</w>"):
        for symbol in _byte_symbols():
            vocab[symbol + suffix] = len(vocab)
    return CLIPTokenizer(vocab=vocab, merges=[], model_max_length=77), len(vocab)


def make_tiny_pipeline(folder, kind: str = "ip2p", seed: int = 0, fp16_copies: bool = False) -> str:
    """fp16_copies: also the weights' fp16 variant (x.fp16.safetensors beside x.safetensors), as SD-Turbo's
    repository has them."""
    import torch
    from diffusers import (AutoencoderKL, EulerAncestralDiscreteScheduler, StableDiffusionImg2ImgPipeline,
                           StableDiffusionInstructPix2PixPipeline, UNet2DConditionModel)
    from transformers import CLIPTextConfig, CLIPTextModel

    torch.manual_seed(seed)
    tokenizer, vocab_size = tiny_tokenizer()
    text_encoder = CLIPTextModel(CLIPTextConfig(
        vocab_size=vocab_size, hidden_size=16, intermediate_size=32, num_attention_heads=2, num_hidden_layers=1,
        max_position_embeddings=77, projection_dim=16, bos_token_id=0, eos_token_id=1, pad_token_id=1))
    unet = UNet2DConditionModel(
        sample_size=8, in_channels=8 if kind == "ip2p" else 4, out_channels=4, block_out_channels=UNET_CHANNELS,
        layers_per_block=1, down_block_types=("CrossAttnDownBlock2D", "DownBlock2D"),
        up_block_types=("UpBlock2D", "CrossAttnUpBlock2D"), cross_attention_dim=16, attention_head_dim=4,
        norm_num_groups=4)
    vae = AutoencoderKL(  # four blocks: downscale 8, as Stable Diffusion's VAE
        in_channels=3, out_channels=3, block_out_channels=(4, 4, 8, 8), layers_per_block=1,
        down_block_types=("DownEncoderBlock2D",) * 4, up_block_types=("UpDecoderBlock2D",) * 4,
        latent_channels=4, norm_num_groups=4, sample_size=64)
    scheduler = EulerAncestralDiscreteScheduler(beta_start=0.00085, beta_end=0.012, beta_schedule="scaled_linear",
                                                timestep_spacing="trailing")
    cls = StableDiffusionInstructPix2PixPipeline if kind == "ip2p" else StableDiffusionImg2ImgPipeline
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pipe = cls(vae=vae, text_encoder=text_encoder, tokenizer=tokenizer, unet=unet, scheduler=scheduler,
                   safety_checker=None, feature_extractor=None, requires_safety_checker=False)
        pipe.save_pretrained(str(folder))
        if fp16_copies:
            pipe.to(torch.float16).save_pretrained(str(folder), variant="fp16")
    return str(folder)


UNET_CHANNELS = (8, 16)  # the tiny UNet's block_out_channels: the adapter's features must match them


def make_tiny_adapter(folder, seed: int = 0, safetensors: bool = False) -> str:
    """A T2I-Adapter with random weights for the tiny UNet (about 70 kB); .bin as TencentARC's depth adapter has
    it, or safetensors."""
    import torch
    from diffusers import T2IAdapter

    torch.manual_seed(seed)
    adapter = T2IAdapter(in_channels=3, channels=list(UNET_CHANNELS), num_res_blocks=1, downscale_factor=8,
                         adapter_type="full_adapter")
    adapter.save_pretrained(str(folder), safe_serialization=safetensors)
    return str(folder)


def tiny_geometry(h: int, w: int, shape: str = "ball"):
    """A LookGeometry of an object as a projector (fx = w) sees it, from its ray hits: 'ball' a sphere before a wall,
    'slope' a wall that leans away to the right: two depths for the same frame, to show the drawing follows them."""
    import numpy as np

    from ...lapig_core.lgst.world.geometry import from_hits

    fx = fy = float(w)
    cx, cy = w / 2, h / 2
    v, u = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    rays = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u)], -1)
    if shape == "ball":
        z = np.full((h, w), 2.0)
        centre, radius = np.array([0.0, 0.0, 1.6]), 0.3
        b = rays @ centre
        disc = b ** 2 - (rays ** 2).sum(-1) * (centre @ centre - radius ** 2)
        hit = disc > 0
        t = (b - np.sqrt(np.where(hit, disc, 0.0))) / (rays ** 2).sum(-1)
        z = np.where(hit, t, z)
    else:
        z = 1.5 + 1.5 * u / w
    points = rays * z[..., None]
    normals = np.zeros_like(points)
    normals[..., 2] = -1.0
    return from_hits(points, normals, np.array([0.0, -1.0, 0.0]), fx, fy, cx, cy, note=f"tiny {shape}")
