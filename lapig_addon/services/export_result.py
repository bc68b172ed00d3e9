"""Export the current result for a real projector: native-resolution PNG plus a JSON sidecar.

The file holds the pixels the projector light shows (blender/result_sinks.ProjectorLightSink): both
take the result's ports.ProjectorFrame, placed and rounded by lapig_core's one frame function.
"""
from __future__ import annotations

import glob
import os

from ...lapig_core.export import projector_image as export
from ...lapig_core.export.result_files import output_name, read_output_image, read_summary, stored_bit_depth
from ...lapig_core.multi.result_files import is_multi_result
from . import light_sidecar
from .crossfade import crossfades, export_crossfades
from .export_source import addon_version, result_folder
from .ports import ProjectorFrame
from .sinks import ProjectorImageFile
from .state import ExportSettings


def newest_result(root: str) -> str:
    """The result folder under `root` written last ('' when there is none): the one a pipeline's last
    stylize made, saved into the .blend or not."""
    summaries = glob.glob(os.path.join(glob.escape(root), "*", "result.json"))
    return os.path.dirname(max(summaries, key=os.path.getmtime)) if summaries else ""


def _check(settings: ExportSettings):
    problem = settings.problem()
    if problem:
        raise ValueError(problem)


def metadata(store, folder: str, summary: dict) -> dict:
    return {"prompt": summary.get("prompt"), "backend": summary.get("backend"), "seed": summary.get("seed"),
            "styles": summary.get("lgst", {}).get("styles"), "psa": summary.get("psa"),
            "psa_settings": summary.get("psa_settings"), "metrics": summary.get("metrics"),
            "surface_reach": summary.get("surface_reach"),
            # refined on the rig: open-loop and refined PSNR of captures, steps, seconds, the noise floor
            "refine": summary.get("refine"),
            **light_sidecar.sidecar_fields(folder),
            **store.rig_metadata(),
            # 8 for results stored before results were 16-bit: a 16-bit file then holds 8 bits of data
            "result_bit_depth": stored_bit_depth(folder, output_name(folder, "projector")),
            **store.software()}


def result_frame(store, folder: str, bit_depth: int, image=None, summary: dict | None = None) -> ProjectorFrame:
    """The result's projector frame for the scene's projector; `image`: the stored projector image when the
    caller holds it already (Generate), else it is read once from the folder."""
    model = store.projector_model()
    image = read_output_image(folder, "projector") if image is None else image
    return ProjectorFrame(image, model.width, model.height, bit_depth, folder=folder,
                          summary=read_summary(folder) if summary is None else summary)


def export_current(store, settings: ExportSettings, result: str | None = None) -> dict:
    """Write the projector image of `result` (None: the scene's result)."""
    _check(settings)
    folder = result_folder(store, result)
    if is_multi_result(folder):  # one image per projector: services/multi_export writes them
        from .multi_export import export_multi

        return export_multi(store, settings, folder)
    frame = result_frame(store, folder, settings.bit_depth)
    sink = ProjectorImageFile(settings.path, metadata(store, folder, frame.summary), addon_version())
    sink.show(frame)
    table = light_sidecar.write_table_beside(sink.written["image"], folder)  # with a light report only
    return {**sink.written, **({"projector_table": table} if table else {})}


def export_crossfade(store, directory: str, settings: ExportSettings, result: str | None = None,
                     on_progress=None) -> list:
    """Write the crossfade frames of `result` (None: the scene's result) into `directory` (absolute). A result of
    several projectors: a folder per projector, directory/projector_<k>/ (services/crossfade)."""
    _check(settings)
    folder = result_folder(store, result)
    if not directory:
        raise ValueError("Choose a folder for the crossfade frames")
    summary = read_summary(folder)
    if is_multi_result(folder):
        common = {key: summary.get(key) for key in ("prompt", "backend", "seed", "psa", "metrics", "refine")}
        return export_crossfades(store, directory, settings.crossfade_frames, settings.bit_depth, folder,
                                 {**common, **store.rig_metadata(), **store.software()}, addon_version(),
                                 on_progress=on_progress)
    [fade] = crossfades(store, folder)
    return export.crossfade_sequence(directory, fade.start, fade.end, frames=settings.crossfade_frames,
                                     width=fade.width, height=fade.height, bit_depth=settings.bit_depth,
                                     ease="smooth", gamma=fade.gamma, metadata=metadata(store, folder, summary),
                                     source_labels=fade.labels, lapig_version=addon_version(), on_progress=on_progress)
