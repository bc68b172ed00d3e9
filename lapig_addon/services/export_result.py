"""Export the current result for a real projector: native-resolution PNG plus a JSON sidecar.

The file holds the pixels the projector light shows (result_preview.show_result_on_projector):
both place and round the stored result with lapig_core's one frame function.
"""
from __future__ import annotations

import glob
import os

import bpy

from ...lapig_core.export import projector_image as export
from ...lapig_core.export.result_files import (output_name, read_output_image, read_result_image, read_summary,
                                               stored_bit_depth)
from ..blender import scene_state
from ..blender.scene_state import projector_model
from .panel_state import result_blocker, rig_blocker
from .state import ExportSettings


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


def result_folder(scene, chosen: str | None = None) -> str:
    """The result to export: `chosen` (a result folder made from the scene's capture), else the scene's."""
    state = scene_state.read(scene)
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


def newest_result(root: str) -> str:
    """The result folder under `root` written last ('' when there is none): the one a pipeline's last
    stylize made, saved into the .blend or not."""
    summaries = glob.glob(os.path.join(glob.escape(root), "*", "result.json"))
    return os.path.dirname(max(summaries, key=os.path.getmtime)) if summaries else ""


def _check(settings: ExportSettings):
    problem = settings.problem()
    if problem:
        raise ValueError(problem)


def metadata(scene, folder: str, summary: dict) -> dict:
    return {"prompt": summary.get("prompt"), "backend": summary.get("backend"), "seed": summary.get("seed"),
            "styles": summary.get("lgst", {}).get("styles"), "psa": summary.get("psa"),
            "psa_settings": summary.get("psa_settings"), "metrics": summary.get("metrics"),
            "surface_reach": summary.get("surface_reach"),
            **scene_state.rig_metadata(scene),
            # 8 for results stored before results were 16-bit: a 16-bit file then holds 8 bits of data
            "result_bit_depth": stored_bit_depth(folder, output_name(folder, "projector")),
            "software_blender": bpy.app.version_string}


def export_current(scene, settings: ExportSettings, result: str | None = None) -> dict:
    """Write the projector image of `result` (None: the scene's result)."""
    _check(settings)
    folder = result_folder(scene, result)
    summary = read_summary(folder)
    model = projector_model(scene_state.rig_objects(scene)[0])
    return export.export_projector_image(settings.path, read_output_image(folder, "projector"), model.width,
                                         model.height, bit_depth=settings.bit_depth,
                                         metadata=metadata(scene, folder, summary), lapig_version=addon_version())


def export_crossfade(scene, directory: str, settings: ExportSettings, result: str | None = None,
                     on_progress=None) -> list:
    """Write the crossfade frames of `result` (None: the scene's result)."""
    _check(settings)
    folder = result_folder(scene, result)
    if not directory:
        raise ValueError("Choose a folder for the crossfade frames")
    summary = read_summary(folder)
    model = projector_model(scene_state.rig_objects(scene)[0])
    b = read_output_image(folder, "projector")
    try:
        a, labels = read_result_image(folder, "projector_nopsa"), ["without PSA", "with PSA"]
    except FileNotFoundError:
        a, labels = b * 0, ["black", "with PSA"]
    return export.crossfade_sequence(bpy.path.abspath(directory), a, b, frames=settings.crossfade_frames,
                                     width=model.width, height=model.height,
                                     bit_depth=settings.bit_depth, ease="smooth", gamma=model.gamma,
                                     metadata=metadata(scene, folder, summary), source_labels=labels,
                                     lapig_version=addon_version(), on_progress=on_progress)
