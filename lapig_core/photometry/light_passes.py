"""Light maps from a light studio's Cycles passes, on any thread (no bpy).

blender/light_render renders the projector's light (and the room's) from the projector's viewpoint into
multilayer EXR files (LightPasses: a folder of their own); maps() reads them and turns Cycles' Diffuse Direct,
Diffuse Color and index passes into ProjectorLightMaps, so a job does this arithmetic on a worker thread while
only the renders stay on Blender's main thread.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass

import numpy as np

from ..common.exr import read_exr_channels
from .light_maps import repair_dropouts
from .units import LUMA, lux_from_diffuse_direct

TARGET_INDEX, REGION_INDEX = 7, 9  # the object's and the marked region's pass indices in the studio


class LightRenderError(ValueError):
    """A region that does not exist or lights nothing, a rig without a projector: said in one line."""


@dataclass
class ProjectorLightMaps:
    white_lux: np.ndarray  # (H, W) lux a white frame gives
    ambient_lux: np.ndarray  # (H, W) lux of the room alone
    albedo: np.ndarray  # (H, W) luminance share the surface reflects
    on_object: np.ndarray  # (H, W) bool: the ray hits the target object
    region: np.ndarray  # (H, W) bool: the marked region (the object when none is marked)
    white_radiance: np.ndarray | None = None  # (H, W) the render's luminance share (W/m2/sr) under white


def _find(channels: dict, *names) -> np.ndarray | None:
    for key, value in channels.items():
        if any(key.endswith(n) for n in names):
            return value
    return None


def _rgb(channels: dict, *names) -> np.ndarray:
    planes = [_find(channels, *(f"{n}.{c}" for n in names)) for c in "RGB"]
    if any(p is None for p in planes):
        raise LightRenderError(f"the render has no {names[0]} pass")
    return np.stack(planes, -1)


@dataclass
class LightPasses:
    """A light studio's renders: the white frame's EXR and, with room light, the room's, in `folder` (theirs
    alone: maps() and discard() remove it)."""

    folder: str
    white: str
    room: str | None = None  # None: a dark room
    region: str = ""  # how the region is marked: "group" (its own part), "material" (its index), "" the object

    def maps(self) -> ProjectorLightMaps:
        """The maps (lux at the light's power as the studio rendered it); the files go."""
        try:
            return self._maps()
        finally:
            self.discard()

    def _maps(self) -> ProjectorLightMaps:
        lit = read_exr_channels(self.white)
        white_lux = lux_from_diffuse_direct(_rgb(lit, "Diffuse Direct", "DiffDir"))
        white_lux = repair_dropouts(white_lux)  # lost shadow rays on a mesh's edges
        albedo = _rgb(lit, "Diffuse Color", "DiffCol") @ LUMA
        ob_index = _find(lit, "Object Index.X", "IndexOB.X", "IndexOB.V", "Object Index.V")
        ma_index = _find(lit, "Material Index.X", "IndexMA.X", "IndexMA.V", "Material Index.V")
        if ob_index is None or ma_index is None:
            raise LightRenderError("the render has no object or material index pass")
        in_group = np.abs(ob_index - REGION_INDEX) < 0.5  # the vertex group's part
        on_object = (np.abs(ob_index - TARGET_INDEX) < 0.5) | in_group
        if self.region == "group":
            region = in_group
        elif self.region == "material":
            region = on_object & (np.abs(ma_index - REGION_INDEX) < 0.5)
        else:
            region = on_object
        ambient = np.zeros_like(white_lux)
        if self.room is not None:
            ambient = lux_from_diffuse_direct(_rgb(read_exr_channels(self.room), "Diffuse Direct", "DiffDir"))
        radiance = _rgb(lit, "Combined", "Image") @ LUMA
        return ProjectorLightMaps(white_lux, ambient, albedo, on_object, region, radiance)

    def discard(self):
        """Remove the files (again: harmless)."""
        shutil.rmtree(self.folder, ignore_errors=True)


def sum_projector_maps(maps: "list[ProjectorLightMaps]") -> ProjectorLightMaps:
    """Several projectors' maps over the same samples (the camera's pixels: light_render's LightStudio with a
    view), each white_lux already at its projector's own lumens, as one: light adds, so the white frames'
    illuminance is their sum; the room's light is in the maps that rendered it (the first's; the others' are
    0) and adds too. The object, the region and the albedo are the view's: the same in every map."""
    if not maps:
        raise ValueError("no projectors' light to add")
    first = maps[0]
    for m in maps[1:]:
        if m.white_lux.shape != first.white_lux.shape:
            raise ValueError(f"light maps over other samples: {m.white_lux.shape} and {first.white_lux.shape}")
    radiance = (None if any(m.white_radiance is None for m in maps) else sum(m.white_radiance for m in maps))
    return ProjectorLightMaps(sum(m.white_lux for m in maps), sum(m.ambient_lux for m in maps), first.albedo,
                              np.logical_or.reduce([m.on_object for m in maps]),
                              np.logical_or.reduce([m.region for m in maps]), radiance)


def projector_shares(lux: "list[np.ndarray]", valid: np.ndarray) -> list[float]:
    """Each projector's share of the light on the valid samples (its lux over all of theirs, summed there): the
    report's 'who lights the object'. All 0 where no projector lights them."""
    valid = np.asarray(valid, bool)
    totals = [float(np.asarray(x, np.float64)[valid].sum()) for x in lux]
    whole = sum(totals)
    return [t / whole if whole > 0 else 0.0 for t in totals]
