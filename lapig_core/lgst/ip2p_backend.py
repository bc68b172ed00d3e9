"""Optional LGST backend: InstructPix2Pix (Brooks et al.) through diffusers, as in the public LAPIG code.

Two paths share one loaded pipeline:
- stylize(): the pipeline itself with the public code's settings (Euler-Ancestral, 10 steps, text guidance
  7.5, image guidance 1.0, input at 256 px). It runs under no_grad, so it is only for previews.
- prepare()/forward(): a few-step deterministic DDIM sampler written here from the pipeline's parts
  (text encoder, VAE, UNet, noise schedule). theta is the prompt embedding, so PSA's gradients reach it.

Depth conditioning (issue 53): with depth_adapter (a T2I-Adapter's folder, lapig_core/diffusion/depth_condition) and
geometry (the object as the projector sees it), the adapter's features of the object's depth are computed once in
prepare() and added by the UNet at every step of both paths, so the drawing follows the object's shape; PSA then
adapts theta as without it (the features are fixed, like the surface).

diffusers/transformers are imported lazily: importing lapig_core.lgst stays light, and machines without
them (or without the weights) still get the default 'styletransfer' backend. Nothing is downloaded unless
the caller passes allow_download=True.
"""
from __future__ import annotations

import functools
import importlib.util
import os
from pathlib import Path

import torch
import torch.utils.checkpoint

from .base import LGSTUnavailable, ThetaBackend
from .styletransfer_backend import resize

DEFAULT_MODEL = "timbrooks/instruct-pix2pix"  # the public checkpoint, when no model is given
REQUIREMENTS = "pip install -r requirements-ip2p.txt"


def _is_local_path(model: str) -> bool:
    """A folder rather than a Hub id ('owner/name' also contains a slash, so only clear paths count)."""
    return (os.path.isabs(model) or model.startswith((".", "~")) or (os.sep == "\\" and "\\" in model)
            or os.path.exists(model))


def _missing_message(model: str, detail: str = "") -> str:
    if _is_local_path(model):
        where = str(Path(model).expanduser())
        fetch = f"`hf download {DEFAULT_MODEL} --local-dir {where}`"
    else:
        where = f"'{model}' (Hugging Face cache)"
        fetch = f"`hf download {model}` (or pass allow_download=True once)"
    msg = (f"InstructPix2Pix weights not found at {where}; download them in the add-on preferences (Diffusion "
           f"models > Download), or with {fetch} and choose that folder (Diffusion models > Use Folder, or "
           f"`stylize --ip2p-model`), or use the default 'styletransfer' backend")
    return msg + (f" ({detail})" if detail else "")


def model_status(model: str | None = None) -> tuple[bool, str]:
    """(weights present locally, where / why not): file-system checks only, loads and downloads nothing."""
    model = model or DEFAULT_MODEL
    for module, package in (("diffusers", "diffusers"), ("transformers", "transformers")):
        if importlib.util.find_spec(module) is None:
            return False, (f"InstructPix2Pix needs the '{package}' package ({REQUIREMENTS}); or use the "
                           f"default 'styletransfer' backend")
    if _is_local_path(model):
        folder = Path(model).expanduser()
        if (folder / "model_index.json").is_file():
            return True, f"InstructPix2Pix from {folder}"
        return False, _missing_message(model)
    try:
        from huggingface_hub import try_to_load_from_cache
    except ImportError:  # pragma: no cover - diffusers depends on huggingface_hub
        return False, _missing_message(model, "huggingface_hub is not installed")
    cached = try_to_load_from_cache(model, "model_index.json")
    if isinstance(cached, str):
        return True, f"InstructPix2Pix '{model}' from the Hugging Face cache"
    return False, _missing_message(model)


def _pick_device(device) -> torch.device:
    """'auto' (or None): CUDA, then Apple's MPS, else the CPU, as everything else picks its device."""
    from ..common import compute_device

    return compute_device.resolve(device or compute_device.AUTO)


@functools.lru_cache(maxsize=2)
def _load_pipeline(model: str, device: str, allow_download: bool):
    """The frozen pipeline, shared by every backend instance in this process (loading takes seconds)."""
    if importlib.util.find_spec("diffusers") is None or importlib.util.find_spec("transformers") is None:
        raise LGSTUnavailable(f"InstructPix2Pix needs diffusers and transformers ({REQUIREMENTS}) or use "
                              f"the default 'styletransfer' backend")
    if _is_local_path(model) and not (Path(model).expanduser() / "model_index.json").is_file():
        raise LGSTUnavailable(_missing_message(model))  # fail at once, diffusers would treat it as a Hub id
    from diffusers import EulerAncestralDiscreteScheduler, StableDiffusionInstructPix2PixPipeline

    dev = torch.device(device)
    source = str(Path(model).expanduser()) if _is_local_path(model) else model
    half = dev.type in ("cuda", "mps")  # fp16 is slow or unsupported on CPU
    if _is_local_path(model):  # the weights' bytes are on disk: check they fit before loading them
        from ..diffusion import device_fit
        from ..diffusion.catalogue import ModelError

        try:
            half = device_fit.require_fit(source, dev, "InstructPix2Pix").dtype == "float16"
        except ModelError as exc:
            raise LGSTUnavailable(str(exc)) from None
    dtype = torch.float16 if half else torch.float32
    try:
        pipe = StableDiffusionInstructPix2PixPipeline.from_pretrained(
            source, dtype=dtype, local_files_only=not allow_download)
    except Exception as exc:  # OSError offline/missing files, ValueError for a broken folder, ...
        raise LGSTUnavailable(_missing_message(model, f"{type(exc).__name__}: {exc}")) from exc
    pipe.scheduler = EulerAncestralDiscreteScheduler.from_config(pipe.scheduler.config)
    pipe = pipe.to(dev)
    pipe.set_progress_bar_config(disable=True)
    for part in (pipe.unet, pipe.vae, pipe.text_encoder):
        part.eval().requires_grad_(False)  # gradients only go to theta, the weights stay fixed
    return pipe


def work_shape(h: int, w: int, size: int, multiple: int) -> tuple[int, int]:
    """(h, w) scaled so the longer side is `size`, both multiples of `multiple` (the VAE's downscale)."""
    scale = size / max(h, w)
    return (max(multiple, int(round(h * scale / multiple)) * multiple),
            max(multiple, int(round(w * scale / multiple)) * multiple))


class PromptDiffusionBackend(ThetaBackend):
    """What the diffusion backends share (InstructPix2Pix, the one-step model): theta is the prompt's text
    embedding, and the lit surface is taken at the model's working size. A subclass has `pipe`, `device`, `size`."""

    def _encode_text(self, text: str) -> torch.Tensor:
        tok = self.pipe.tokenizer
        ids = tok(text, padding="max_length", max_length=tok.model_max_length, truncation=True,
                  return_tensors="pt").input_ids.to(self.device)
        return self.pipe.text_encoder(ids)[0]

    def _take_surface(self, surface, prompt, mix, model_words: str):
        """Check the surface and the prompt, keep the surface and the working size; (prompt text, notes)."""
        from .prompt_mapping import validate_prompt

        if surface.ndim != 4 or surface.shape[:2] != (1, 3):
            raise ValueError(f"surface must be (1,3,H,W), got {tuple(surface.shape)}")
        text, notes = validate_prompt(prompt)
        if mix is not None:
            notes.append(f"style mixes are ignored by {model_words}: it follows the prompt only")
        self.surface = surface.detach().float().clamp(0, 1)
        self.out_size = tuple(self.surface.shape[-2:])
        self.work_size = work_shape(*self.out_size, self.size, self.pipe.vae_scale_factor)
        return text, notes


class InstructPix2PixBackend(PromptDiffusionBackend):
    """InstructPix2Pix edits the white-lit surface as the prompt instructs; theta = prompt embedding."""

    name = "instruct-pix2pix"
    takes_device = True
    takes_geometry = True  # the object's depth, for the depth adapter (pipeline.stylize passes it)

    def __init__(self, model: str | None = None, allow_download: bool = False, steps: int = 10,
                 guidance: float = 7.5, image_guidance: float = 1.0, size: int = 256, psa_steps: int = 4,
                 device=None, checkpointing: bool = False, depth_adapter: str | None = None, geometry=None,
                 depth_scale: float = 1.0):
        """model: Hub id or local folder (default: 'timbrooks/instruct-pix2pix' in the Hugging Face cache).
        allow_download: let diffusers fetch missing weights (off: never touch the network).
        steps: Euler-Ancestral steps of stylize(); psa_steps: DDIM steps of the differentiable forward().
        guidance / image_guidance: classifier-free guidance weights for the text and the input image.
        size: longer side of the image the model works on (the public code uses 256).
        checkpointing: recompute each UNet call in backward instead of storing its activations
        (less memory for PSA on the full model, about one more forward pass of time).
        depth_adapter: a T2I-Adapter's folder (the depth adapter of the model manager); with geometry (a
        lgst/world/geometry.LookGeometry, or "capture" where there is no 3D model) the drawing follows the
        object's depth; depth_scale weighs its features (the adapter pipeline's adapter_conditioning_scale).
        """
        if int(steps) < 1 or int(psa_steps) < 1:
            raise ValueError(f"steps and psa_steps must be >= 1, got {steps} and {psa_steps}")
        if int(size) < 8:
            raise ValueError(f"size must be >= 8, got {size}")
        self.model = model or DEFAULT_MODEL
        self.allow_download = bool(allow_download)
        self.steps, self.psa_steps, self.size = int(steps), int(psa_steps), int(size)
        self.guidance, self.image_guidance = float(guidance), float(image_guidance)
        self.device = _pick_device(device)
        self.checkpointing = bool(checkpointing)
        self.depth_adapter, self.geometry, self.depth_scale = depth_adapter or None, geometry, float(depth_scale)
        self._depth: list | None = None  # the adapter's features of the object's depth, fixed in prepare()
        self._theta: list[torch.Tensor] = []
        self._info: dict = {}

    @classmethod
    def availability(cls, model: str | None = None, **options) -> tuple[bool, str]:
        return model_status(model)

    @property
    def pipe(self):
        return _load_pipeline(self.model, str(self.device), self.allow_download)

    # -- setup -----------------------------------------------------------------------------------
    def prepare(self, surface, prompt, seed=0, mix=None):
        text, notes = self._take_surface(surface, prompt, mix, "InstructPix2Pix")
        pipe = self.pipe
        dtype = pipe.unet.dtype
        with torch.no_grad():
            self._image = resize(self.surface.to(self.device), self.work_size)
            self._uncond = self._encode_text("").to(dtype)
            cond = self._encode_text(text)
            # image latents as the pipeline makes them: the VAE mode, unscaled (InstructPix2Pix convention)
            self._image_latents = pipe.vae.encode((self._image * 2 - 1).to(dtype)).latent_dist.mode()
        gen = torch.Generator().manual_seed(int(seed))  # CPU generator: same noise on every device
        shape = (1, pipe.vae.config.latent_channels, *self._image_latents.shape[-2:])
        self._noise = torch.randn(shape, generator=gen).to(self.device, dtype)
        # float32 leaf even when the UNet runs fp16, so Adam's small steps are not rounded away
        self._theta = [cond.detach().float().clone().requires_grad_(True)]
        self._anchor = [cond.detach().float().clone()]
        depth_info = self._prepare_depth(notes)
        self._info = {"backend": self.name, "model": self.model, "prompt": text, "seed": int(seed),
                      "steps": self.steps, "psa_steps": self.psa_steps, "guidance": self.guidance,
                      "image_guidance": self.image_guidance, "size": list(self.work_size),
                      "device": str(self.device), "dtype": str(dtype).replace("torch.", ""),
                      "styles": [], "effects": [], "theta_numel": self._theta[0].numel(), "notes": notes}
        if depth_info:
            self._info["depth"] = depth_info

    def _prepare_depth(self, notes: list) -> dict:
        """The depth adapter's features of the object's depth at the working size (self._depth), or None with a
        note where there is no depth to follow; what result.json says of it."""
        self._depth = None
        if not self.depth_adapter:
            return {}
        from ..diffusion import depth_condition

        image = depth_condition.depth_image(self.geometry, *self.work_size)
        if image is None:
            notes.append(depth_condition.NO_DEPTH)
            return {"adapter": self.depth_adapter, "used": False}
        unet = self.pipe.unet
        adapter = depth_condition.load_adapter(self.depth_adapter, str(self.device),
                                               str(unet.dtype).replace("torch.", ""))
        self._depth = depth_condition.adapter_features(adapter, image, unet, self.depth_scale)
        self.depth_image = image
        return {"adapter": self.depth_adapter, "used": True, "scale": self.depth_scale,
                "on_object": round(float((image[0, 0] > 0).float().mean()), 3)}

    def _depth_residuals(self, batch: int) -> dict:
        from ..diffusion.depth_condition import residuals

        return {} if self._depth is None else {"down_intrablock_additional_residuals": residuals(self._depth, batch)}

    # -- rendering -------------------------------------------------------------------------------
    def _timesteps(self) -> list[int]:
        # "trailing" spacing: the first step starts at the last training timestep (pure noise), which
        # few-step DDIM needs; the pipeline's "leading" spacing would start from a partly clean latent
        n_train = len(self.pipe.scheduler.alphas_cumprod)
        return [int(round(n_train - i * n_train / self.psa_steps)) - 1 for i in range(self.psa_steps)]

    def _eps(self, latents, t, cond):
        """Guided noise prediction with the pipeline's three branches (text+image, image, none)."""
        pipe, dtype = self.pipe, self.pipe.unet.dtype
        uncond, img = self._uncond, self._image_latents
        three = self.image_guidance != 1.0  # at weight 1 the unconditional branch cancels out exactly
        n = 3 if three else 2
        x = torch.cat([torch.cat([latents] * n), torch.cat([img, img, torch.zeros_like(img)][:n])], dim=1)
        emb = torch.cat([cond.to(dtype), uncond, uncond][:n])
        out = pipe.unet(x, t, encoder_hidden_states=emb, return_dict=False, **self._depth_residuals(n))[0].float()
        e_text, e_img = out[0:1], out[1:2]
        e_none = out[2:3] if three else e_img
        return e_none + self.guidance * (e_text - e_img) + self.image_guidance * (e_img - e_none)

    def forward(self):
        """Deterministic DDIM (eta 0) from the noise fixed in prepare(); differentiable w.r.t. theta."""
        self._require_prepared()
        pipe = self.pipe
        alphas = pipe.scheduler.alphas_cumprod.to(self.device, torch.float32)
        prediction = pipe.scheduler.config.get("prediction_type", "epsilon")
        latents = self._noise.float()
        steps = self._timesteps()
        for i, t in enumerate(steps):
            a_t = alphas[t]
            a_prev = alphas[steps[i + 1]] if i + 1 < len(steps) else torch.ones_like(a_t)
            x_in = latents.to(pipe.unet.dtype)
            if self.checkpointing and torch.is_grad_enabled():
                model_out = torch.utils.checkpoint.checkpoint(self._eps, x_in, t, self._theta[0],
                                                              use_reentrant=False)
            else:
                model_out = self._eps(x_in, t, self._theta[0])
            if prediction == "v_prediction":
                x0 = a_t.sqrt() * latents - (1 - a_t).sqrt() * model_out
                eps = a_t.sqrt() * model_out + (1 - a_t).sqrt() * latents
            else:
                x0 = (latents - (1 - a_t).sqrt() * model_out) / a_t.sqrt()
                eps = model_out
            latents = a_prev.sqrt() * x0 + (1 - a_prev).sqrt() * eps
        scale = pipe.vae.config.scaling_factor
        image = pipe.vae.decode((latents / scale).to(pipe.vae.dtype), return_dict=False)[0].float()
        image = ((image + 1) / 2).clamp(0, 1)
        return resize(image, self.out_size).to(self.surface.device)

    def stylize(self, surface, prompt, seed=0, mix=None):
        """The pipeline with the public code's settings (Euler-Ancestral, seeded); no graph."""
        self.prepare(surface, prompt, seed=seed, mix=mix)
        pipe = self.pipe
        gen = torch.Generator(device=self.device).manual_seed(int(seed))
        hook = None
        if self._depth is not None:  # the pipeline calls the UNet itself: the depth's features go in with each call
            def with_depth(module, args, kwargs):
                sample = args[0] if args else kwargs["sample"]
                return args, {**kwargs, **self._depth_residuals(sample.shape[0])}

            hook = pipe.unet.register_forward_pre_hook(with_depth, with_kwargs=True)
        try:
            with torch.no_grad():
                out = pipe(image=self._image.to(pipe.unet.dtype), prompt_embeds=self._theta[0].detach().to(
                    pipe.unet.dtype), negative_prompt_embeds=self._uncond, num_inference_steps=self.steps,
                    guidance_scale=self.guidance, image_guidance_scale=self.image_guidance, generator=gen,
                    output_type="pt").images
        finally:
            if hook is not None:
                hook.remove()
        return resize(out.float().clamp(0, 1), self.out_size).to(self.surface.device)
