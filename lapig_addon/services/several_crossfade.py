"""Crossfades of a result of several projectors (issues 36 and 38): each projector's crossfade between its own two
images of the result (projector_k_nopsa.png, or black where the result has none, to projectors[k].image: the
refined one where made, as Export), mixed in that projector's linear light (its own gamma), as one projector's
Export Crossfade and Play Crossfade make of its image (lapig_core/export/projector_image.crossfade_sequence and
crossfade_frames).

- export_crossfades: a folder per projector, <directory>/projector_<k>/crossfade_0001.png .. with crossfade.json
  (its sidecar names the projector, with its share of a Light Report where one ran); every folder or none (the folders made here are removed after a failure).
- crossfade_sets: the frames played live, one list per frame with one array per projector (rigs/live_output
  plays them on the windows of several, presented together).
"""
from __future__ import annotations

import os
import shutil

from ...lapig_core.export import projector_image as export
from ...lapig_core.export.result_files import read_summary
from . import light_sidecar


def projector_folder(directory: str, k: int) -> str:
    return os.path.join(directory, f"projector_{k + 1}")


def crossfade_pairs(folder: str) -> list:
    """(result.json's entry, start image, end image, labels) per projector of a result of several."""
    from ...lapig_core.multi.result_files import nopsa_images, projector_images

    shown = projector_images(folder)
    without = nopsa_images(folder)
    if without is None:
        return [(entry, image * 0, image, ["black", "with PSA"]) for entry, image in shown]
    return [(entry, start, image, ["without PSA", "with PSA"]) for (entry, image), start in zip(shown, without)]


def rig_models(store, count: int) -> tuple:
    """Each projector's model (its gamma), checked against the result's count of projectors."""
    models = tuple(store.projector_models())
    if len(models) != count:
        raise ValueError(f"the result was made for {count} projectors; the rig has {len(models)}: generate again")
    return models


def export_crossfades(store, directory: str, frames: int, bit_depth: int, folder: str, metadata: dict,
                      lapig_version: str, on_progress=None) -> list:
    """Write each projector's crossfade into its folder under `directory`; every frame's path, projector by
    projector."""
    pairs = crossfade_pairs(folder)
    models = rig_models(store, len(pairs))
    made, paths = [], []
    try:
        for k, ((entry, start, end, labels), model) in enumerate(zip(pairs, models)):
            out = projector_folder(directory, k)
            if not os.path.isdir(out):
                os.makedirs(out)
                made.append(out)
            width, height = entry["size"]
            meta = {**metadata, **light_sidecar.several_sidecar_fields(folder, k),  # the Light Report's, where run
                    "projector": {"index": k + 1, "count": len(pairs), "name": entry.get("name"),
                                  "resolution": [width, height], "gamma": model.gamma}}
            heard = None if on_progress is None else (
                lambda f, m, k=k: on_progress((k + f) / len(pairs), f"projector {k + 1}: {m}"))
            paths += export.crossfade_sequence(out, start, end, frames=frames, width=width, height=height,
                                               bit_depth=bit_depth, ease="smooth", gamma=model.gamma,
                                               metadata=meta, source_labels=labels, lapig_version=lapig_version,
                                               on_progress=heard)
    except BaseException:
        for out in made:  # every projector's folder or none
            shutil.rmtree(out, ignore_errors=True)
        raise
    return paths


def crossfade_sets(store, folder: str, bit_depth: int, frames: int):
    """The frames played live (a generator): one list per frame, each projector's frame at its native size in its
    own gamma (what export_crossfades writes)."""
    pairs = crossfade_pairs(folder)
    models = rig_models(store, len(pairs))
    each = [export.crossfade_frames(start, end, frames, width=entry["size"][0], height=entry["size"][1],
                                    bit_depth=bit_depth, gamma=model.gamma)
            for (entry, start, end, _), model in zip(pairs, models)]
    return (list(frame) for frame in zip(*each))


def sizes(folder: str) -> list:
    """Each projector's native size in the result (width, height)."""
    return [tuple(entry["size"]) for entry in read_summary(folder).get("projectors") or []]
