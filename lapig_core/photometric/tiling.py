# SPDX-License-Identifier: GPL-3.0-or-later
"""A fully convolutional network over a frame of any size, in overlapping tiles, without seams.

CompenNeSt and PCNet see a bounded neighbourhood of each pixel, and they are shift-equivariant for
shifts by a multiple of 4 (two stride-2 levels). So a tile whose input reaches CONTEXT pixels past
its core, and starts on a multiple of 4, gives the core exactly what the whole frame would. Each
tile also counts for BLEND pixels past its core, on a linear ramp into its neighbour's core, so
whatever is left of the tile edges fades out instead of showing as a seam. Frames whose sides are not
multiples of 4 (e.g. 1366x768) are padded by edge replication and cropped back.
"""
from __future__ import annotations

from typing import Callable

import torch
import torch.nn.functional as F

MULTIPLE = 4
CONTEXT = 48  # input pixels past a tile's core: beyond the networks' reach (about 30 px)
BLEND = 16  # of which the inner ones ramp into the neighbour's core


def _ramp(n_before: int, core: int, n_after: int, blend: int) -> torch.Tensor:
    """1-D weights of a tile input: 1 over the core, ramps over ``blend`` pixels into the context on
    the sides that have a neighbour (n_* > 0), 0 beyond."""
    w = torch.zeros(n_before + core + n_after)
    w[n_before:n_before + core] = 1.0
    for start, step, n in ((n_before - 1, -1, n_before), (n_before + core, 1, n_after)):
        for k in range(min(blend, n)):
            w[start + step * k] = 1.0 - (k + 1) / (blend + 1)
    return w


def _spans(length: int, tile: int, context: int):
    """(input start, input end, core start, core end) of each tile along one padded axis."""
    for core0 in range(0, length, tile):
        core1 = min(core0 + tile, length)
        yield max(core0 - context, 0), min(core1 + context, length), core0, core1


def tiled(net: Callable[..., torch.Tensor], inputs: list[torch.Tensor], tile: int,
          context: int = CONTEXT, blend: int = BLEND) -> torch.Tensor:
    """net(*inputs) for (1, C, H, W) inputs of one frame, computed ``tile`` x ``tile`` cores at a
    time (tile a multiple of 4); the result equals the whole-frame output up to float rounding."""
    if tile % MULTIPLE or context % MULTIPLE or tile < MULTIPLE:
        raise ValueError(f"tile {tile} and context {context} must be positive multiples of {MULTIPLE}")
    h, w = inputs[0].shape[-2:]
    pad_h, pad_w = -h % MULTIPLE, -w % MULTIPLE
    if pad_h or pad_w:
        inputs = [F.pad(x, (0, pad_w, 0, pad_h), mode="replicate") for x in inputs]
    H, W = h + pad_h, w + pad_w
    out = weight = None
    with torch.no_grad():
        for y0, y1, cy0, cy1 in _spans(H, tile, context):
            wy = _ramp(cy0 - y0, cy1 - cy0, y1 - cy1, blend)
            for x0, x1, cx0, cx1 in _spans(W, tile, context):
                wx = _ramp(cx0 - x0, cx1 - cx0, x1 - cx1, blend)
                # channels-last: CPU convolutions of this size run about 1.8x faster in that layout (and GPUs'
                # tensor cores take it too)
                y = net(*[x[..., y0:y1, x0:x1].contiguous(memory_format=torch.channels_last) for x in inputs])
                if out is None:  # where the net ran: a GPU's tiles add up on the GPU
                    out = torch.zeros(*y.shape[:2], H, W, dtype=y.dtype, device=y.device)
                    weight = torch.zeros(1, 1, H, W, dtype=y.dtype, device=y.device)
                tile_weight = (wy[:, None] * wx[None, :]).to(device=y.device, dtype=y.dtype)
                out[..., y0:y1, x0:x1] += y * tile_weight
                weight[..., y0:y1, x0:x1] += tile_weight
    return (out / weight)[..., :h, :w]
