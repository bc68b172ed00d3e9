"""The captures in a scene's data folder: which one a pipeline made last."""
from __future__ import annotations

import glob
import os

from ....lapig_core.capture.dataset import read_setup_json


def newest_capture(data_root: str, fingerprint: str = "") -> str:
    """The setup folder under `data_root` captured last ('' when there is none): the one a pipeline's last
    capture made, saved into the .blend or not. fingerprint: only captures of this rig state ('' any)."""
    found = []
    for path in glob.glob(os.path.join(glob.escape(data_root), "*", "setups", "*", "setup.json")):
        try:
            if fingerprint and read_setup_json(path).get("fingerprint") != fingerprint:
                continue
            found.append((os.path.getmtime(path), os.path.dirname(path)))
        except (OSError, ValueError):  # half-removed or damaged: not a capture to point a pipeline to
            continue
    return max(found)[1] if found else ""
