"""What the headless commands print: one progress line per new message, a JSON summary last."""
from __future__ import annotations

import json
import sys

_last_progress = {"message": None}


def print_progress(progress, message):
    """One line per new message (a worker job reports the same state on every poll)."""
    if message == _last_progress["message"]:
        return
    _last_progress["message"] = message
    print(f"[{progress:6.1%}] {message}", flush=True)


def print_json(summary: dict):
    print(json.dumps(summary, sort_keys=True), flush=True)


def print_notes(notes):
    """What the user should know about a result (a cut prompt, a weak match, retrained models), on stderr
    so stdout stays progress lines and the JSON summary."""
    for note in notes:
        print("note: " + " ".join(note.split()), file=sys.stderr, flush=True)
