"""What the headless commands print: one progress line per new message, a JSON summary last."""
from __future__ import annotations

import json

_last_progress = {"message": None}


def print_progress(progress, message):
    """One line per new message (a worker job reports the same state on every poll)."""
    if message == _last_progress["message"]:
        return
    _last_progress["message"] = message
    print(f"[{progress:6.1%}] {message}", flush=True)


def print_json(summary: dict):
    print(json.dumps(summary, sort_keys=True), flush=True)
