# SPDX-License-Identifier: GPL-3.0-or-later
"""The final look and its compensation at the projector's native resolution (or a chosen size up to it).

PSA adapts theta at the working frame; theta does not depend on the resolution, and CompenNeSt is
fully convolutional. So once PSA is done: register the surface references again at the output
size (capture/native_references), render theta's look on the finer white-lit surface
(LGSTBackend.render_at), and compensate it there, in tiles where the memory budget needs them
(photometric/tiling). The projector image is black off the object, from the registration at that
size, like the working one.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import torch

from .capture.native_references import registered_references
from .common.compute_device import memory_budget_mb
from .optics.working_frame import NETWORK_MULTIPLE, WorkingFrameError
from .photometric.tiling import CONTEXT, tiled
from .photometric.training_data import to_tensor

# Measured peaks (no graph, float32): CompenNeSt's activations take about 650 bytes per input pixel
# (1.35 GB at 1920x1080); the frame's own images (references, target, projector image, maps, the
# tile accumulators) about 200 bytes per output pixel.
NET_BYTES_PER_PIXEL = 700
FRAME_BYTES_PER_PIXEL = 200
DEFAULT_BUDGET_MB = 2500
MIN_TILE = 128


class OutputSizeError(WorkingFrameError):
    """An output size over the native frame or over the memory budget; the message says what fits."""


def output_frame(long_side: int, proj_width: int, proj_height: int) -> tuple[int, int]:
    """(width, height) of the output: the native frame for 0, else ``long_side`` on the long side
    (the projector's aspect), at most native."""
    native_long = max(proj_width, proj_height)
    if not long_side or long_side == native_long:
        return proj_width, proj_height
    if long_side > native_long:
        raise OutputSizeError(f"the output size {long_side} is larger than the projector's "
                              f"{proj_width}x{proj_height} frame: use at most {native_long} (or 0 for native)")
    scale = long_side / native_long
    return max(NETWORK_MULTIPLE, round(proj_width * scale)), max(NETWORK_MULTIPLE, round(proj_height * scale))


def _padded(n: int) -> int:
    return -(-n // NETWORK_MULTIPLE) * NETWORK_MULTIPLE


def tile_for(width: int, height: int, budget_mb: float | None = None) -> int:
    """The tile core side that keeps a width x height output within ``budget_mb`` (None:
    DEFAULT_BUDGET_MB): the whole frame when it fits, else the largest square tile that does.
    OutputSizeError (with the largest output of this aspect that fits) when even MIN_TILE tiles do not."""
    budget_mb = DEFAULT_BUDGET_MB if budget_mb is None else budget_mb
    budget = budget_mb * 2 ** 20
    frame = width * height * FRAME_BYTES_PER_PIXEL
    whole = _padded(width) * _padded(height) * NET_BYTES_PER_PIXEL
    if frame + whole <= budget:
        return max(_padded(width), _padded(height))
    tile_side = (int(math.sqrt(max(budget - frame, 0) / NET_BYTES_PER_PIXEL)) - 2 * CONTEXT) // NETWORK_MULTIPLE \
        * NETWORK_MULTIPLE
    if tile_side >= MIN_TILE:
        return tile_side
    smallest_tiles = (MIN_TILE + 2 * CONTEXT) ** 2 * NET_BYTES_PER_PIXEL
    pixels = (budget - smallest_tiles) / FRAME_BYTES_PER_PIXEL  # of the largest output that fits
    scale = math.sqrt(max(pixels, 0) / (width * height))
    fits = (f"the largest output of this aspect that fits is {int(width * scale)}x{int(height * scale)}"
            if scale * min(width, height) >= NETWORK_MULTIPLE else "no output fits, raise the budget")
    need = (frame + min(whole, smallest_tiles)) / 2 ** 20
    raise OutputSizeError(f"a {width}x{height} output needs about {need:.0f} MB, over the {budget_mb:.0f} MB "
                          f"memory budget: {fits}")


@dataclass
class NativeResult:
    target: torch.Tensor  # (1,3,H,W): theta's look at the output size
    projector_image: torch.Tensor  # (1,3,H,W): its compensation, black off the object when asked
    valid: torch.Tensor  # (H,W) bool: where the projector frame lands on the object
    tile: int  # tile core side used (the whole frame when it is one tile)
    seconds: float


def device_tile(width: int, height: int, device, budget_mb: float | None = None) -> int:
    """tile_for with ``budget_mb``, else the budget of the device the frame is compensated on: a share of
    a CUDA device's free memory (compute_device.memory_budget_mb), DEFAULT_BUDGET_MB elsewhere."""
    return tile_for(width, height, budget_mb if budget_mb is not None else memory_budget_mb(device))


def compensate_frame(compensator, target: torch.Tensor, s: torch.Tensor, tile: int) -> torch.Tensor:
    """The compensator's projector image of ``target`` (1,3,H,W) for the surface ``s`` at that size, in
    tiles of ``tile``, where the compensator is (the result stays there)."""
    height, width = target.shape[-2:]
    # a per-pixel compensator (the classical one, where it was chosen) takes its parameters at this size
    per_pixel = compensator.frame_inputs(height, width) if hasattr(compensator, "frame_inputs") else []
    return tiled(lambda x, surface, *more: compensator(x, surface, *more), [target, s, *per_pixel], tile)


def native_output(setup_dir, models, backend, state: dict, width: int, height: int,
                  dark_outside: bool = True, budget_mb: float | None = None,
                  tile: int | None = None) -> NativeResult:
    """theta (``state``, from a PSA result) rendered and compensated at width x height.

    ``models``: the setup's SurfaceModels (its CompenNeSt); ``backend``: the prepared LGST backend
    the state belongs to; ``tile``: the tile core side (None: from the budget: on a CUDA device, from its
    free memory). It runs where the models are; the images come back on the CPU."""
    t0 = time.perf_counter()
    device = models.device
    tile = tile or device_tile(width, height, device, budget_mb)  # refuse before any work
    refs = registered_references(setup_dir, width, height)
    backend.load_state(state)
    target = backend.render_at(to_tensor(refs.white).to(device))
    projector_image = compensate_frame(models.compensator, target, to_tensor(refs.gray).to(device), tile)
    valid = torch.from_numpy(refs.valid)
    if dark_outside:
        projector_image = projector_image * valid[None, None].to(device=projector_image.device,
                                                                 dtype=projector_image.dtype)
    return NativeResult(target.cpu(), projector_image.cpu(), valid, tile, time.perf_counter() - t0)
