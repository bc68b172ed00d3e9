"""Network architectures of the LAPIG pipeline (plain torch, no bpy).

- CompenNeSt: compensation network pi_dagger(x, s) -> projector input.
- PCNet: project-and-capture simulator pi_hat(x, s) -> simulated camera capture.
"""
from torch import nn

from .compennest import CompenNeSt
from .net import count_parameters, describe
from .pcnet import PCNet

# Registry so settings/checkpoints can name an architecture by string.
ARCHS = {CompenNeSt.ARCH_NAME: CompenNeSt, PCNet.ARCH_NAME: PCNet}


def build(name: str, **kwargs) -> nn.Module:
    """Instantiate an architecture by its ARCH_NAME."""
    try:
        return ARCHS[name](**kwargs)
    except KeyError:
        raise ValueError(f"unknown architecture {name!r}; known: {sorted(ARCHS)}") from None


__all__ = ["ARCHS", "CompenNeSt", "PCNet", "build", "count_parameters", "describe"]
