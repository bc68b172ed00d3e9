# SPDX-License-Identifier: GPL-3.0-or-later
"""Is a folder a diffusers pipeline, and is a downloaded model whole: the checks behind 'Use a folder I already
have' and the model's state (absent, ready, damaged).

A diffusers pipeline folder has model_index.json, naming its components ({"unet": ["diffusers",
"UNet2DConditionModel"], "safety_checker": [null, null], ...}); each component named with a library has a folder
with its config (config.json, scheduler_config.json, tokenizer_config.json, preprocessor_config.json) and, for
the networks, its weights. A download writes MANIFEST (each file's size and sha256) once every file is verified;
the state check compares sizes only (quick enough for the preferences' redraw), verify() compares the hashes.
One diffusers model (an adapter: the catalogue's MODEL layout) is a folder with config.json, naming its class, and
its weights beside it.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field

from .catalogue import ModelError

MANIFEST = ".lapig-model.json"
PLAN = ".lapig-download.json"  # in a partial folder: the listing's total, while the download is not whole
PARTIAL_PREFIX = ".partial-"
WEIGHT_SUFFIXES = (".safetensors", ".bin")
CONFIG_NAMES = ("config.json", "scheduler_config.json", "tokenizer_config.json", "preprocessor_config.json")
NETWORKS = ("unet", "vae", "text_encoder", "transformer", "controlnet")  # components that must have weights
ABSENT, READY, DAMAGED = "absent", "ready", "damaged"


def components(index: dict) -> dict[str, tuple]:
    """model_index.json's components that are there (library and class set): name -> (library, class)."""
    out = {}
    for name, value in index.items():
        if name.startswith("_") or not isinstance(value, list) or len(value) != 2:
            continue
        if value[0] is not None and value[1] is not None:
            out[name] = tuple(value)
    return out


def read_index(folder: str) -> dict:
    path = os.path.join(folder, "model_index.json")
    if not os.path.isfile(path):
        raise ModelError(f"{folder} is not a diffusers pipeline: it has no model_index.json (choose the folder "
                         f"that holds model_index.json, unet/, vae/, ...)")
    try:
        with open(path, encoding="utf-8") as f:
            index = json.load(f)
    except (OSError, ValueError) as exc:
        raise ModelError(f"{path} cannot be read as JSON ({exc}): the folder is damaged") from None
    if not isinstance(index, dict) or not components(index):
        raise ModelError(f"{path} names no components: not a diffusers pipeline")
    return index


def check_pipeline(folder: str, pipeline_class: str | None = None) -> dict:
    """model_index.json read and every component's files found; ModelError with what is missing otherwise.
    pipeline_class: the class it must be (a folder of another kind of model is refused here, not at loading)."""
    folder = os.path.abspath(os.path.expanduser(folder or ""))
    if not os.path.isdir(folder):
        raise ModelError(f"no folder at {folder}")
    index = read_index(folder)
    if pipeline_class and index.get("_class_name") not in (pipeline_class, None):
        raise ModelError(f"{folder} holds a {index.get('_class_name')}, not a {pipeline_class}: choose the "
                         f"folder of that model")
    missing = []
    for name in components(index):
        part = os.path.join(folder, name)
        names = os.listdir(part) if os.path.isdir(part) else []
        if not any(n in CONFIG_NAMES for n in names):
            missing.append(f"{name}/ (its config)")
        elif name in NETWORKS and not any(n.endswith(WEIGHT_SUFFIXES) for n in names):
            missing.append(f"{name}/ (its weights)")
    if missing:
        raise ModelError(f"{folder} is not a whole diffusers pipeline: it lacks {', '.join(missing)}")
    return index


def check_model(folder: str, model_class: str | None = None) -> dict:
    """One diffusers model's folder (config.json naming its class, its weights beside it): its config; ModelError
    with what is wrong otherwise. model_class: the class it must be (T2IAdapter)."""
    folder = os.path.abspath(os.path.expanduser(folder or ""))
    if not os.path.isdir(folder):
        raise ModelError(f"no folder at {folder}")
    path = os.path.join(folder, "config.json")
    if not os.path.isfile(path):
        what = f"a {model_class}" if model_class else "a diffusers model"
        raise ModelError(f"{folder} is not {what}: it has no config.json (choose the folder that holds config.json "
                         f"and diffusion_pytorch_model.*)")
    try:
        with open(path, encoding="utf-8") as f:
            config = json.load(f)
    except (OSError, ValueError) as exc:
        raise ModelError(f"{path} cannot be read as JSON ({exc}): the folder is damaged") from None
    found = config.get("_class_name") if isinstance(config, dict) else None
    if not found:
        raise ModelError(f"{path} names no model class: not a diffusers model")
    if model_class and found != model_class:
        raise ModelError(f"{folder} holds a {found}, not a {model_class}: choose the folder of that model")
    if not any(n.endswith(WEIGHT_SUFFIXES) for n in os.listdir(folder)):
        raise ModelError(f"{folder} is not a whole {found}: it lacks its weights (diffusion_pytorch_model.*)")
    return config


def check_layout(folder: str, layout: str = "pipeline", class_name: str | None = None) -> dict:
    """check_pipeline or check_model, as the catalogue's layout of that model says."""
    return check_model(folder, class_name) if layout == "model" else check_pipeline(folder, class_name)


def weights_bytes(folder: str) -> int:
    """The bytes of the weight files the pipeline loads (the memory estimate's base)."""
    total = 0
    for root, _, names in os.walk(folder):
        for name in names:
            if name.endswith(WEIGHT_SUFFIXES):
                total += os.path.getsize(os.path.join(root, name))
    return total


def sha256_of(path: str, chunk: int = 1 << 20) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            digest.update(block)
    return digest.hexdigest()


def git_blob_sha1(path: str) -> str:
    """git's object id of a file (what the Hub's listing gives for files that are not in LFS)."""
    digest = hashlib.sha1(f"blob {os.path.getsize(path)}\0".encode())
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            digest.update(block)
    return digest.hexdigest()


@dataclass
class FolderState:
    state: str  # ABSENT, READY, DAMAGED
    folder: str
    why: str = ""  # for DAMAGED, and ABSENT with a resumable partial download
    size_bytes: int = 0
    partial_bytes: int = 0  # what a stopped download left (Download resumes it)
    problems: list = field(default_factory=list)


def read_manifest(folder: str) -> dict | None:
    try:
        with open(os.path.join(folder, MANIFEST), encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def human_size(n: int) -> str:
    """'5.12 GB', '385.5 MB', '0.2 MB'."""
    return f"{n / 1e9:.2f} GB" if n >= 1e9 else f"{n / 1e6:.1f} MB"


def _planned_bytes(partial: str) -> int:
    try:
        with open(os.path.join(partial, PLAN), encoding="utf-8") as f:
            return int(json.load(f).get("bytes_total", 0))
    except (OSError, ValueError, TypeError, AttributeError):
        return 0


def _folder_bytes(folder: str) -> int:
    return sum(os.path.getsize(os.path.join(r, n)) for r, _, names in os.walk(folder) for n in names)


def folder_state(folder: str, partial: str | None = None, layout: str = "pipeline") -> FolderState:
    """The state of a model folder (quick: sizes, not hashes). A downloaded one has a MANIFEST: each listed file
    must be there with its size; a folder of the user's own has none: it must be a whole pipeline (or model, for
    the MODEL layout)."""
    partial_bytes = _folder_bytes(partial) if partial and os.path.isdir(partial) else 0
    if not os.path.isdir(folder):
        why = ""
        if partial_bytes:
            total = _planned_bytes(partial)
            of = f" of {human_size(total)}" if total else ""
            why = f"a download stopped after {human_size(partial_bytes)}{of}: Download resumes it"
        return FolderState(ABSENT, folder, why, partial_bytes=partial_bytes)
    manifest = read_manifest(folder)
    problems = []
    if manifest is not None:
        for path, info in manifest.get("files", {}).items():
            here = os.path.join(folder, path)
            if not os.path.isfile(here):
                problems.append(f"{path} is missing")
            elif os.path.getsize(here) != int(info.get("size", -1)):
                problems.append(f"{path} has {os.path.getsize(here)} bytes, not {info.get('size')}")
    if not problems:
        try:
            check_layout(folder, layout)
        except ModelError as exc:
            problems.append(str(exc))
    size = _folder_bytes(folder)
    if problems:
        why = f"{problems[0]}" + (f" (and {len(problems) - 1} more)" if len(problems) > 1 else "")
        return FolderState(DAMAGED, folder, why + ": Remove it and download it again", size, partial_bytes, problems)
    return FolderState(READY, folder, "", size, partial_bytes)


def verify(folder: str) -> list[str]:
    """Every file of a downloaded model against its MANIFEST's sha256: the damaged ones' paths."""
    manifest = read_manifest(folder)
    if manifest is None:
        return []
    bad = []
    for path, info in manifest.get("files", {}).items():
        here = os.path.join(folder, path)
        if not os.path.isfile(here) or sha256_of(here) != info.get("sha256"):
            bad.append(path)
    return bad
