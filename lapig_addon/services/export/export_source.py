"""What an export writes from: the result folder chosen (or the scene's), checked against the scene's capture,
and the add-on's version for the sidecars. Shared by the export of one projector and of several (export_result,
export_joint)."""
from __future__ import annotations

import os

from ....lapig_core.export.result_files import read_summary
from ..panel.panel_state import result_blocker, rig_blocker


def addon_version() -> str:
    manifest = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                            "blender_manifest.toml")
    try:
        with open(manifest, encoding="utf-8") as f:
            for line in f:
                if line.startswith("version"):
                    return line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    return "unknown"


def result_folder(store, chosen: str | None = None) -> str:
    """The result to export: `chosen` (a result folder made from the scene's capture), else the scene's."""
    state = store.read()
    blocker = rig_blocker(state.rig) if chosen else result_blocker(state)
    if blocker:
        raise ValueError(blocker)
    if not chosen:
        return state.result_dir
    made_from = read_summary(chosen).get("fingerprint")
    if made_from and state.capture_fingerprint and made_from != state.capture_fingerprint:
        raise ValueError(f"{chosen} was made from another capture than this scene's: export it with the "
                         ".blend it was made with")
    return chosen
