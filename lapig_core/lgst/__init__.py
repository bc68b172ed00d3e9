"""Language-guided style transfer (LGST): I = f_theta(s, T), bpy-free.

    from lapig_core.lgst import get_backend
    lgst = get_backend("styletransfer")
    lgst.prepare(surface, "Make it a stained glass artwork", seed=0)
    target = lgst.forward()              # differentiable w.r.t. lgst.parameters()

Importing this package loads no model; backends load theirs on first use.
"""
from .base import (BACKENDS, LGSTBackend, LGSTUnavailable, available_backends, get_backend,
                   register_backend)
from .styletransfer_backend import StyleTransferBackend

DEFAULT_BACKEND = "styletransfer"
register_backend(DEFAULT_BACKEND, StyleTransferBackend)

__all__ = ["BACKENDS", "DEFAULT_BACKEND", "LGSTBackend", "LGSTUnavailable", "StyleTransferBackend",
           "available_backends", "get_backend", "register_backend"]
