"""Checkpoints with a header: architecture, role, working size (the frame's long side) and the setup
they were trained on.

Loading checks the header before the weights, so a PCNet file given where a CompenNeSt is expected,
or weights fine-tuned on another setup, are refused with a message instead of silently misused.
Pretrained weights carry no setup fingerprint and serve any setup.
"""
from __future__ import annotations

import datetime
import io
import os
from pathlib import Path

import torch

from . import archs
from ..common import denormals
from ..common.atomic import atomic_write_bytes

FORMAT = "lapig-checkpoint"
VERSION = 1
WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"  # the pretrained weights shipped with the extension
PRETRAINED = {  # (arch, role) -> file shipped with the extension
    ("CompenNeSt", "compensation"): "compennest_pretrained.pt",
    ("PCNet", "simulation"): "pcnet_pretrained.pt",
    ("CompenNeSt", "simulation"): "compennest_reversed_pretrained.pt",
}


class CheckpointError(ValueError):
    pass


class NotTrainedYet(CheckpointError):
    """No checkpoint for this setup yet: none saved, or one trained on another setup (as opposed to a
    file that is damaged)."""


HEADER_FIELDS = {"arch": str, "role": str, "working_size": int}  # what loading reads from a header


def make_header(model, role: str, working_size: int, fingerprint: str | None = None, **extra) -> dict:
    return {"format": FORMAT, "version": VERSION, "arch": model.ARCH_NAME, "role": role,
            "working_size": int(working_size), "fingerprint": fingerprint,
            "parameters": archs.count_parameters(model), "torch": str(torch.__version__),
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"), **extra}


def save_checkpoint(path, model, role: str, working_size: int, fingerprint: str | None = None,
                    **extra) -> Path:
    """Write atomically (temporary file, then rename): a full disk never leaves a torn file."""
    header = make_header(model, role, working_size, fingerprint, **extra)
    buf = io.BytesIO()
    torch.save({"header": header, "state_dict": model.state_dict()}, buf)
    return atomic_write_bytes(path, buf.getvalue())


def _read(path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise NotTrainedYet(f"no checkpoint at {path}")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # truncated or not a torch file
        raise CheckpointError(f"{path.name} is not a readable checkpoint ({_first_sentence(exc)})") from None
    header = data.get("header") if isinstance(data, dict) else None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise CheckpointError(f"{path.name} is not a LAPIG checkpoint (no header)")
    for key, kind in HEADER_FIELDS.items():
        if not isinstance(header.get(key), kind):
            problem = "is missing" if key not in header else f"is {header[key]!r}, not {kind.__name__}"
            raise CheckpointError(f"{path.name} has a damaged header: '{key}' {problem}")
    if not isinstance(data.get("state_dict"), dict):
        raise CheckpointError(f"{path.name} holds no weights (no state_dict)")
    return data


def _first_sentence(exc: Exception) -> str:
    """'Type: first sentence' of a loader's error (torch's own explanation spans a page)."""
    lines = str(exc).strip().split(". ")[0].splitlines()
    return f"{type(exc).__name__}: {lines[0][:160]}" if lines else type(exc).__name__


def load_checkpoint(path, arch: str | None = None, role: str | None = None, working_size: int | None = None,
                    fingerprint: str | None = None, scrub: bool = True):
    """(model in eval mode, header); every given expectation must match the header. scrub=False keeps the
    subnormal weights as the file holds them (bench denormals measures what they cost)."""
    data = _read(path)
    h = data["header"]
    name = Path(path).name
    if arch is not None and h["arch"] != arch:
        raise CheckpointError(f"{name} holds a {h['arch']} network, a {arch} was expected")
    if role is not None and h["role"] != role:
        raise CheckpointError(f"{name} is a {h['arch']} trained for {h['role']}, not {role}")
    if working_size is not None and h["working_size"] != working_size:
        raise CheckpointError(f"{name} was trained at {h['working_size']} px, this setup works at "
                              f"{working_size} px: train again at this size")
    if fingerprint is not None and h.get("fingerprint") not in (None, fingerprint):
        raise NotTrainedYet(f"{name} was trained on another setup (the projector, camera or object "
                            f"changed since): fine-tune the models again")
    try:
        model = archs.build(h["arch"])
    except ValueError as exc:
        raise CheckpointError(f"{name} holds an {exc}") from None
    try:
        model.load_state_dict(data["state_dict"])
    except RuntimeError as exc:
        raise CheckpointError(f"{name} does not fit the {h['arch']} network: {exc}") from None
    if scrub:
        denormals.scrub_module(model)  # subnormal weights slow some CPUs several times (common/denormals)
    model.eval()
    return model, h


def pretrained_path(arch: str, role: str, weights_dir=None) -> Path:
    """weights_dir: another set of pretrained weights (e.g. ones you pretrained yourself); default: the shipped."""
    try:
        return Path(weights_dir or WEIGHTS_DIR) / PRETRAINED[(arch, role)]
    except KeyError:
        raise CheckpointError(f"no pretrained weights for {arch} ({role})") from None


def load_pretrained(arch: str, role: str, working_size: int | None = None, weights_dir=None):
    """The pretrained model (shipped, or from weights_dir), or a clear error when its file is missing."""
    path = pretrained_path(arch, role, weights_dir)
    if not path.is_file():
        raise CheckpointError(f"the pretrained {arch} weights are missing ({path}); reinstall the extension "
                              f"or train from scratch")
    return load_checkpoint(path, arch=arch, role=role, working_size=working_size)


def new_model(arch: str, seed: int = 0):
    """A freshly initialised network, the same for the same seed."""
    state = torch.random.get_rng_state()
    torch.manual_seed(seed)
    try:
        return archs.build(arch)
    finally:
        torch.random.set_rng_state(state)


def file_size_mb(path) -> float:
    return os.path.getsize(path) / 2 ** 20
