"""Where the prompt model runs: in this process, or in a helper process.

Blender's UI asks for 'subprocess' when the add-on registers: loading the model in-process holds the
GIL long enough to freeze the UI (bench ui). Torch-free, so that registering does not import torch.
"""
from __future__ import annotations

MODES = ("inprocess", "subprocess")
DEFAULT_MODE = "inprocess"  # scripts, tests and headless runs
_mode = DEFAULT_MODE


def set_embedding_mode(mode: str) -> None:
    global _mode
    if mode not in MODES:
        raise ValueError(f"embedding mode must be 'inprocess' or 'subprocess', got {mode!r}")
    _mode = mode


def embedding_mode() -> str:
    return _mode
