"""Export the result of several projectors: one native-resolution image per projector with its sidecar, and
the rig's MPCDI package (issue 36).

export_result.export_current takes this way when the scene's rig has more than one projector (the Export button,
*Export MPCDI Package*, `export`). Each projector's file holds the result's image for it at its native size (the
ProjectorImageFile sink, as one projector's export): '<name>_1.png', '<name>_2.png', ... beside the chosen path,
each with its JSON sidecar naming the projector. The package (lapig_core/multi/mpcdi_export) is written first: a
path it cannot be written to stops the export before any image is, and nothing at that path or of the result is
lost.
"""
from __future__ import annotations

import os
from pathlib import Path

from ....lapig_core.export.result_files import capture_of_result, read_summary, stored_bit_depth
from ....lapig_core.multi.capture_set import joint_model_path
from ..light import light_sidecar
from .crossfade import export_crossfades
from .export_result import result_fields, write_projector_file
from .export_source import addon_version
from ..ports import ProjectorFrame


def projector_path(path: str, k: int) -> str:
    """The file of projector k (0-based) for the export path `path`: its name with _<k+1> before .png."""
    stem, ext = os.path.splitext(path)
    return f"{stem}_{k + 1}{ext or '.png'}"


def metadata(store, summary: dict) -> dict:
    """What each projector's sidecar says of the result, the rig and the software (its own projector added)."""
    return {**result_fields(summary), "metrics": summary.get("metrics"), "multi": summary.get("multi"),
            **store.rig_metadata(), **store.software()}


def write_sl_package(store, path, model, names, version: str = "2.0"):
    """The 'sl' (shader lamp: nDisplay, TouchDesigner) package: poses, frusta and 3D surface points per texel
    from the scene (store.sl_geometry, main thread: bpy), alpha maps from the joint model as the '2d' one."""
    from ....lapig_core.multi.blend import alpha_maps, blend_weights
    from ....lapig_core.multi.mpcdi_export import write_rig_mpcdi_sl

    geometry = store.sl_geometry()
    alphas = alpha_maps(model.maps, blend_weights(model.maps))
    for name, pm, alpha in zip(names, geometry["models"], alphas):
        if tuple(alpha.shape) != (pm.height, pm.width):
            raise ValueError(f"projector {name}: the capture was made at {alpha.shape[1]}x{alpha.shape[0]}, "
                             f"the projector is now {pm.width}x{pm.height}: capture again")
    return write_rig_mpcdi_sl(path, names, geometry["models"], geometry["matrices"], geometry["points"], alphas,
                              gammas=model.alpha_gammas, version=version)


class JointExportWay:
    """Export's steps for a rig of several projectors (see export_result.ProjectorExportWay)."""

    def export(self, store, settings, folder, mpcdi, images, profile, mpcdi_version):
        """Every projector's image (images=False: none) and, with `mpcdi`, the rig's package: the package first."""
        from ....lapig_core.multi.joint_model import JointModel
        from ....lapig_core.multi.mpcdi_export import write_rig_mpcdi
        from ....lapig_core.multi.result_files import projector_images

        shown = projector_images(folder)
        summary = read_summary(folder)
        rig = store.read().rig
        names = tuple(entry["name"] for entry, _ in shown)
        if rig.projectors and tuple(rig.projectors) != names:
            raise ValueError(f"the result was made for projectors {', '.join(names)}; the rig now has "
                             f"{', '.join(rig.projectors)}: generate again")
        written = {"images": [], "sidecars": [], "mpcdi": None}
        if mpcdi:
            model_path = joint_model_path(capture_of_result(folder, summary))
            if not model_path.is_file():
                raise ValueError(f"the result's capture has no joint model ({model_path}): capture again")
            joint = JointModel.load(model_path)
            written["mpcdi"] = str(write_sl_package(store, mpcdi, joint, names, mpcdi_version) if profile == "sl"
                                   else write_rig_mpcdi(mpcdi, joint, names, version=mpcdi_version))
            written["mpcdi_version"] = mpcdi_version
        common = metadata(store, summary)
        for k, (entry, image) in enumerate(shown if images else []):
            width, height = entry["size"]
            meta = {**common, **light_sidecar.sidecar_fields(folder, k),  # the Light Report's, where run
                    "projector": {"index": k + 1, "count": len(shown), "name": entry["name"],
                                  "resolution": [width, height]},
                    "result_bit_depth": stored_bit_depth(folder, Path(entry["image"]).stem)}
            frame = ProjectorFrame(image, width, height, settings.bit_depth, folder=folder, summary=summary)
            one = write_projector_file(projector_path(settings.path, k), frame, meta)
            written["images"].append(str(one["image"]))
            written["sidecars"].append(str(one["sidecar"]))
        if images:  # every projector's row of the Light Report's table, where it ran
            table = light_sidecar.write_table_beside(settings.path, folder)
            if table is not None:
                written["table"] = str(table)
        return written

    def crossfade(self, store, directory, settings, folder, on_progress):
        """A folder per projector, directory/projector_<k>/, each its own crossfade (services/export/crossfade)."""
        summary = read_summary(folder)
        common = {key: summary.get(key) for key in ("prompt", "backend", "seed", "psa", "metrics", "refine")}
        return export_crossfades(store, directory, settings.crossfade_frames, settings.bit_depth, folder,
                                 {**common, **store.rig_metadata(), **store.software()}, addon_version(),
                                 on_progress=on_progress)
