"""Language-guided style transfer (LGST): I = f_theta(s, T), bpy-free.

    from lapig_core.lgst import get_backend
    lgst = get_backend("styletransfer")
    lgst.prepare(surface, "Make it a stained glass artwork", seed=0)
    target = lgst.forward()              # differentiable w.r.t. lgst.parameters()

Importing this package loads no model; backends load theirs on first use.
"""
from .base import (BACKENDS, LGSTBackend, LGSTUnavailable, available_backends, backend_class, get_backend,
                   register_backend)
from .arbitrary_backend import ArbitraryStyleBackend
from .ip2p_backend import InstructPix2PixBackend
from .one_step_backend import OneStepBackend
from .styletransfer_backend import StyleTransferBackend

DEFAULT_BACKEND = "styletransfer"
register_backend(DEFAULT_BACKEND, StyleTransferBackend)
register_backend("arbitrary", ArbitraryStyleBackend)  # reference-image styles (style_images=[...])
register_backend("instruct-pix2pix", InstructPix2PixBackend)  # optional: diffusers + weights, loaded lazily
register_backend("one-step", OneStepBackend)  # optional: the one-step model (SD-Turbo) of the model manager



def prepared_backend(backend: str, surface, prompt: str, seed: int = 0, mix=None, options=None):
    """(the backend prepared for ``surface`` and ``prompt``, why it fell back or None): a backend that cannot
    run here (e.g. InstructPix2Pix without its weights) falls back to the offline default, and says why."""
    lgst = get_backend(backend, **(options or {}))
    try:
        lgst.prepare(surface, prompt, seed=seed, mix=mix)
        return lgst, None
    except LGSTUnavailable as exc:
        if backend == DEFAULT_BACKEND:
            raise
        fallback = f"'{backend}' is not available ({exc}); used '{DEFAULT_BACKEND}' instead"
    lgst = get_backend(DEFAULT_BACKEND)
    lgst.prepare(surface, prompt, seed=seed, mix=mix)
    return lgst, fallback


__all__ = ["ArbitraryStyleBackend", "BACKENDS", "DEFAULT_BACKEND", "InstructPix2PixBackend", "LGSTBackend", "LGSTUnavailable", "OneStepBackend",
           "StyleTransferBackend", "available_backends", "backend_class", "get_backend", "prepared_backend",
           "register_backend"]
