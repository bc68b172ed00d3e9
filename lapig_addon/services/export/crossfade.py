"""A result's crossfades (issues 36 and 38): each projector's between its own two images of the result (its image
without PSA, or black where the result has none, to the image it shows: the refined one where made, as Export),
mixed in that projector's linear light (its own gamma) by lapig_core/export/projector_image.crossfade_sequence and
crossfade_frames. A result of one projector has the scene's projector's crossfade; a result of several one per
projector, checked against the rig's count.

- crossfades: each projector's Crossfade, the one place the result's projectors are read for it.
- export_crossfades: the crossfades of several, a folder per projector, <directory>/projector_<k>/crossfade_0001.png
  .. with crossfade.json (its sidecar names the projector, with its share of a Light Report where one ran); every
  folder or none (the folders made here are removed after a failure). One projector's goes into <directory> itself
  (export_result.export_crossfade).
- frame_sets: the frames played live, one list per frame with one array per projector (rigs/live_output plays them
  on the window, or on the windows of several, presented together).
"""
from __future__ import annotations

import os
import shutil
from dataclasses import dataclass

import numpy as np

from ....lapig_core.export import projector_image as export
from ....lapig_core.export.result_files import read_output_image, read_result_image, read_summary
from ..light import light_sidecar


@dataclass(frozen=True)
class Crossfade:
    """One projector's crossfade: from `start` to `end` (its stored images), at its native size in its gamma."""

    start: np.ndarray
    end: np.ndarray
    labels: list
    width: int
    height: int
    gamma: float
    name: str | None = None  # the projector's, in a result of several


def crossfades(store, folder: str) -> list:
    """Each projector's Crossfade of the result in `folder`: the scene's projector's for a result of one."""
    from ....lapig_core.multi.result_files import is_multi_result, nopsa_images, projector_images

    if not is_multi_result(folder):
        model = store.projector_model()
        end = read_output_image(folder, "projector")
        try:
            start, labels = read_result_image(folder, "projector_nopsa"), ["without PSA", "with PSA"]
        except FileNotFoundError:
            start, labels = end * 0, ["black", "with PSA"]
        return [Crossfade(start, end, labels, model.width, model.height, model.gamma)]
    shown, without = projector_images(folder), nopsa_images(folder)
    labels = ["black", "with PSA"] if without is None else ["without PSA", "with PSA"]
    starts = [image * 0 for _, image in shown] if without is None else without
    models = rig_models(store, len(shown))
    return [Crossfade(start, image, labels, *entry["size"], model.gamma, entry.get("name"))
            for (entry, image), start, model in zip(shown, starts, models)]


def projector_folder(directory: str, k: int) -> str:
    return os.path.join(directory, f"projector_{k + 1}")


def rig_models(store, count: int) -> tuple:
    """Each projector's model (its gamma), checked against the result's count of projectors."""
    models = tuple(store.projector_models())
    if len(models) != count:
        raise ValueError(f"the result was made for {count} projectors; the rig has {len(models)}: generate again")
    return models


def export_crossfades(store, directory: str, frames: int, bit_depth: int, folder: str, metadata: dict,
                      lapig_version: str, on_progress=None) -> list:
    """Write each projector's crossfade of a result of several into its folder under `directory`; every frame's
    path, projector by projector."""
    fades = crossfades(store, folder)
    made, paths = [], []
    try:
        for k, fade in enumerate(fades):
            out = projector_folder(directory, k)
            if not os.path.isdir(out):
                os.makedirs(out)
                made.append(out)
            meta = {**metadata, **light_sidecar.sidecar_fields(folder, k),  # the Light Report's, where run
                    "projector": {"index": k + 1, "count": len(fades), "name": fade.name,
                                  "resolution": [fade.width, fade.height], "gamma": fade.gamma}}
            heard = None if on_progress is None else (
                lambda f, m, k=k: on_progress((k + f) / len(fades), f"projector {k + 1}: {m}"))
            paths += export.crossfade_sequence(out, fade.start, fade.end, frames=frames, width=fade.width,
                                               height=fade.height, bit_depth=bit_depth, ease="smooth",
                                               gamma=fade.gamma, metadata=meta, source_labels=fade.labels,
                                               lapig_version=lapig_version, on_progress=heard)
    except BaseException:
        for out in made:  # every projector's folder or none
            shutil.rmtree(out, ignore_errors=True)
        raise
    return paths


def frame_sets(store, folder: str, bit_depth: int, frames: int):
    """The frames played live (a generator): one list per frame, each projector's frame at its native size in its
    own gamma (what the export writes)."""
    each = [export.crossfade_frames(f.start, f.end, frames, width=f.width, height=f.height, bit_depth=bit_depth,
                                    gamma=f.gamma) for f in crossfades(store, folder)]
    return (list(frame) for frame in zip(*each))


def sizes(folder: str) -> list:
    """Each projector's native size in a result of several (width, height)."""
    return [tuple(entry["size"]) for entry in read_summary(folder).get("projectors") or []]
