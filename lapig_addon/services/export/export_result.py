"""Export the current result for real projectors: each projector's image at its native resolution, with a JSON
sidecar, and for a rig of several the rig's MPCDI package; Export Crossfade.

One export (export_current, export_crossfade) for either model strategy (services/state.Rig.strategy): the
request and the result folder are checked once, then the way chosen by the rig writes. One projector's file is
the export path itself (ProjectorExportWay, below); a rig of several writes '<name>_1.png', '<name>_2.png', ...
and the package (services/export/export_joint). Each file holds the pixels the projector light shows
(blender/result_sinks.ProjectorLightSink): both take the result's ports.ProjectorFrame, placed and rounded by
lapig_core's one frame function, written by the one ProjectorImageFile sink.
"""
from __future__ import annotations

import glob
import os

from ....lapig_core.export import projector_image as export
from ....lapig_core.export.result_files import output_name, read_output_image, read_summary, stored_bit_depth
from ..light import light_sidecar
from .crossfade import crossfades, sizes
from .export_source import addon_version, result_folder
from ..ports import ProjectorFrame
from .sinks import ProjectorImageFile
from ..state import ExportSettings
from ..ways import chosen_way

MPCDI_PROFILES = ("2d", "sl")
MPCDI_VERSIONS = ("2.0", "1.0")  # 2.0: Watchout 7, nDisplay, Pixera; 1.0: Watchout 6, the VESA reference


def newest_result(root: str) -> str:
    """The result folder under `root` written last ('' when there is none): the one a pipeline's last
    stylize made, saved into the .blend or not."""
    summaries = glob.glob(os.path.join(glob.escape(root), "*", "result.json"))
    return os.path.dirname(max(summaries, key=os.path.getmtime)) if summaries else ""


def _check(settings: ExportSettings, profile: str = "2d", mpcdi_version: str = "2.0"):
    problem = settings.problem()
    if profile not in MPCDI_PROFILES:
        problem = f"MPCDI profile must be one of {', '.join(MPCDI_PROFILES)}, got {profile!r}"
    if mpcdi_version not in MPCDI_VERSIONS:
        problem = f"MPCDI version must be one of {', '.join(MPCDI_VERSIONS)}, got {mpcdi_version!r}"
    if problem:
        raise ValueError(problem)


def export_current(store, settings: ExportSettings, result: str | None = None, mpcdi: str | None = None,
                   images: bool = True, profile: str = "2d", mpcdi_version: str = "2.0") -> dict:
    """Write the projector image(s) of `result` (None: the scene's result; images=False: none) and, with `mpcdi`, the
    rig's package in `profile` ('2d' or 'sl'). Returns what was written: one projector's {'image', 'sidecar'} (and
    'projector_table'), several projectors' {'images': [paths], 'sidecars': [paths], 'mpcdi': path or None} (and
    'mpcdi_version', 'table')."""
    _check(settings, profile, mpcdi_version)
    folder = result_folder(store, result)
    return export_way(store).export(store, settings, folder, mpcdi, images, profile, mpcdi_version)


def export_crossfade(store, directory: str, settings: ExportSettings, result: str | None = None,
                     on_progress=None) -> list:
    """Write the crossfade frames of `result` (None: the scene's result) into `directory` (absolute). A result of
    several projectors: a folder per projector, directory/projector_<k>/ (services/export/crossfade)."""
    _check(settings)
    folder = result_folder(store, result)
    if not directory:
        raise ValueError("Choose a folder for the crossfade frames")
    return export_way(store).crossfade(store, directory, settings, folder, on_progress)


def export_way(store):
    """The one place Export's way is chosen: a rig of several writes an image per projector, and its package."""
    return chosen_way(store.read().rig, ProjectorExportWay, "export.export_joint:JointExportWay")()


def result_fields(summary: dict) -> dict:
    """What every sidecar says of the result first: its prompt, backend, seed, styles and PSA."""
    return {"prompt": summary.get("prompt"), "backend": summary.get("backend"), "seed": summary.get("seed"),
            "styles": summary.get("lgst", {}).get("styles"), "psa": summary.get("psa")}


def write_projector_file(path: str, frame: ProjectorFrame, meta: dict) -> dict:
    """One projector's PNG and its JSON sidecar ({'image', 'sidecar'}), through the file sink."""
    sink = ProjectorImageFile(path, meta, addon_version())
    sink.show(frame)
    return sink.written


def metadata(store, folder: str, summary: dict) -> dict:
    return {**result_fields(summary), "psa_settings": summary.get("psa_settings"), "metrics": summary.get("metrics"),
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


class ProjectorExportWay:
    """Export's steps for one projector: export(store, settings, folder, mpcdi, images, profile, mpcdi_version)
    writes its image at the export path, with its sidecar and, where a Light Report ran, its table beside it;
    crossfade(store, directory, settings, folder, on_progress) writes its crossfade into `directory`."""

    def export(self, store, settings, folder, mpcdi, images, profile, mpcdi_version):
        _one_projectors(folder)
        if mpcdi:
            raise ValueError("an MPCDI package is the calibration of a rig of several projectors; the rig has one")
        frame = result_frame(store, folder, settings.bit_depth)
        written = write_projector_file(settings.path, frame, metadata(store, folder, frame.summary))
        table = light_sidecar.write_table_beside(written["image"], folder)  # with a light report only
        return {**written, **({"projector_table": table} if table else {})}

    def crossfade(self, store, directory, settings, folder, on_progress):
        _one_projectors(folder)
        [fade] = crossfades(store, folder)
        return export.crossfade_sequence(directory, fade.start, fade.end, frames=settings.crossfade_frames,
                                         width=fade.width, height=fade.height, bit_depth=settings.bit_depth,
                                         ease="smooth", gamma=fade.gamma,
                                         metadata=metadata(store, folder, read_summary(folder)),
                                         source_labels=fade.labels, lapig_version=addon_version(),
                                         on_progress=on_progress)


def _one_projectors(folder: str) -> None:
    """ValueError where the result was made for a rig of several: its images are not this projector's."""
    count = len(sizes(folder))
    if count:
        raise ValueError(f"the result was made for {count} projectors; the rig has 1: generate again")
