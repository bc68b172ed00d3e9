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
from .styletransfer_backend import StyleTransferBackend

DEFAULT_BACKEND = "styletransfer"
register_backend(DEFAULT_BACKEND, StyleTransferBackend)
register_backend("arbitrary", ArbitraryStyleBackend)  # reference-image styles (style_images=[...])
register_backend("instruct-pix2pix", InstructPix2PixBackend)  # optional: diffusers + weights, loaded lazily

__all__ = ["ArbitraryStyleBackend", "BACKENDS", "DEFAULT_BACKEND", "InstructPix2PixBackend", "LGSTBackend", "LGSTUnavailable",
           "StyleTransferBackend", "available_backends", "backend_class", "get_backend", "register_backend"]
