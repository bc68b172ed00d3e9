# SPDX-License-Identifier: GPL-3.0-or-later
"""MPCDI 2.0 and 1.0 packages for several projectors: warps and blend maps as media servers read them.

version "2.0" (the default) or "1.0" (Watchout 6, the VESA reference reader; mpcdi_xml says how the descriptor
differs). A 1.0 package's level (figure 3-2 of 1.0 / 1a): '2d' 1 with a warp grid of at most 32x32, 3 with a
finer one, one more with beta maps; 'sl' 1, 3 with distortion maps, one more with beta maps. Its PNG maps are
8-bit by default (the reference reader decodes 8-bit grey or RGB only) and its PFM header is "-1.000000".

A .mpcdi file (VESA MPCDI 2.0, 19 May 2015) is a ZIP with mpcdi.xml and, per region, a geometry warp
(PFM), an alpha blend map and optionally a beta (black level) map (PNG), all at the container's root
(3.3). Two profiles are written:

  '2d'  2D media (Watchout, BrightSign): each region's warp maps its pixels to normalised (u, v) in
        the region's frame (3.6.2), blended by its alpha map.
  'sl'  shader lamps (nDisplay, TouchDesigner): each warp texel holds the 3D surface point that pixel
        lights (3.6.3), with the projector's frustum and coordinate frame (3.5.2); one region per
        buffer; an optional per-pixel lens distortion map.

Levels follow table 3-2 and 3-3: geometry 1 for a '2d' warp grid of at most 32x32 and for 'sl' without
distortion maps, 2 otherwise; color 1 with alpha maps only, 2 with single-channel beta maps as well.

Alpha maps are stored with gamma `region.gamma` embedded: stored = alpha ** (1 / gamma), so that a
reader's decode linear = stored ** gammaEmbedded (2.5.1.2.4's gamma definition, which the alpha map's
gammaEmbedded refers to) returns the linear weights given here. Beta maps are stored linear.

Everything is checked before anything is written, and the file appears whole or not at all
(common/atomic): a failed write keeps the previous file at that path. No bpy, no code in data.
"""
from __future__ import annotations

import datetime as dt
import io
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..common import atomic
from ..common.imageio import encode_png
from .mpcdi_model import (BIT_DEPTHS, GEOMETRIC_UNITS, INTERPOLATIONS, LEVEL_1_WARP_GRID, ORIGINS_OF_3D_DATA,
                          PROFILES, MpcdiBuffer, MpcdiCoordinateFrame, MpcdiFrustum, MpcdiRegion, check_2d_map,
                          check_3d_map, check_coordinate_frame, check_frustum, check_id, check_number,
                          check_resolution, check_weight_map)
from .mpcdi_xml import VERSIONS, PackageFacts, RegionFiles, descriptor_xml
from .pfm import encode_pfm

__all__ = ["MpcdiBuffer", "MpcdiCoordinateFrame", "MpcdiFrustum", "MpcdiRegion", "PROFILES", "write_mpcdi",
           "encode_alpha", "DESCRIPTOR"]

DESCRIPTOR = "mpcdi.xml"  # the one XML file every package holds (3.5.2)
EXTENSION = ".mpcdi"  # 3.1
_SIZE_TOLERANCE_PX = 1.0  # a region's pixels against its share of the buffer: rounding only
_EDGE_TOLERANCE = 1e-9


def encode_alpha(alpha: np.ndarray, gamma: float, bit_depth: int) -> np.ndarray:
    """The stored integers of a linear alpha map with `gamma` embedded: round(scale * alpha ** (1/gamma))."""
    scale = (1 << bit_depth) - 1
    stored = np.rint(np.power(np.asarray(alpha, np.float64), 1.0 / gamma) * scale)
    return stored.astype(np.uint16 if bit_depth == 16 else np.uint8)


def _encode_linear(values: np.ndarray, bit_depth: int) -> np.ndarray:
    return encode_alpha(values, 1.0, bit_depth)


@dataclass(frozen=True, eq=False)
class _Prepared:
    """One region's checked maps, as the files will hold them."""
    region: MpcdiRegion
    warp: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray | None
    distortion: np.ndarray | None


def _check_region_in_buffer(region: MpcdiRegion, buffer: MpcdiBuffer, size: tuple[int, int]) -> None:
    """The region lies inside the buffer's normalised frame and its pixels match its share of it."""
    what = f"region {region.id!r}"
    x = check_number(region.x, f"{what} x", 0.0, 1.0)
    y = check_number(region.y, f"{what} y", 0.0, 1.0)
    xsize = check_number(region.xsize, f"{what} xsize", 0.0, 1.0, low_open=True)
    ysize = check_number(region.ysize, f"{what} ysize", 0.0, 1.0, low_open=True)
    if x + xsize > 1.0 + _EDGE_TOLERANCE or y + ysize > 1.0 + _EDGE_TOLERANCE:
        raise ValueError(f"{what} reaches past buffer {buffer.id!r}: x + xsize = {x + xsize:.6g}, "
                         f"y + ysize = {y + ysize:.6g} (at most 1)")
    buffer_w, buffer_h = check_resolution(buffer.resolution, f"buffer {buffer.id!r}")
    expected_w, expected_h = xsize * buffer_w, ysize * buffer_h
    if abs(expected_w - size[0]) > _SIZE_TOLERANCE_PX or abs(expected_h - size[1]) > _SIZE_TOLERANCE_PX:
        raise ValueError(f"{what} is {size[0]}x{size[1]} pixels but covers {xsize:.6g}x{ysize:.6g} of buffer "
                         f"{buffer.id!r}'s {buffer_w}x{buffer_h}, i.e. {expected_w:.6g}x{expected_h:.6g} pixels")


def _prepare_region(region: MpcdiRegion, buffer: MpcdiBuffer, profile: str) -> _Prepared:
    if not isinstance(region, MpcdiRegion):
        raise ValueError(f"buffer {buffer.id!r} holds a {type(region).__name__}, not an MpcdiRegion")
    what = f"region {check_id(region.id, 'region')!r}"
    size = check_resolution(region.resolution, what)
    _check_region_in_buffer(region, buffer, size)
    check_number(region.gamma, f"{what} alpha gamma", 0.0, low_open=True)
    check_number(region.signal_gamma, f"{what} signal gamma", 0.0, low_open=True)
    alpha = check_weight_map(region.alpha, f"{what} alpha", size)
    beta = None if region.beta is None else check_weight_map(region.beta, f"{what} beta", size)
    if profile == "2d":
        for name in ("frustum", "coordinate_frame", "distortion"):
            if getattr(region, name) is not None:
                raise ValueError(f"{what} has a {name.replace('_', ' ')}: profile '2d' has none (3.5.2)")
        return _Prepared(region, check_2d_map(region.warp, f"{what} warp", size), alpha, beta, None)
    if region.frustum is None or region.coordinate_frame is None:
        raise ValueError(f"{what} needs a frustum and a coordinate frame: profile 'sl' requires both (3.5.2)")
    check_frustum(region.frustum, what)
    check_coordinate_frame(region.coordinate_frame, what)
    distortion = None if region.distortion is None else check_2d_map(region.distortion, f"{what} distortion", size)
    return _Prepared(region, check_3d_map(region.warp, f"{what} warp", size), alpha, beta, distortion)


def _prepare(profile: str, buffers) -> tuple[list[MpcdiBuffer], list[_Prepared]]:
    if isinstance(buffers, MpcdiBuffer) or not isinstance(buffers, Sequence) or not buffers:
        raise ValueError("buffers must be a non-empty list of MpcdiBuffer")
    buffer_ids, region_ids, prepared = set(), set(), []
    for buffer in buffers:
        if not isinstance(buffer, MpcdiBuffer):
            raise ValueError(f"buffers must hold MpcdiBuffer objects, got a {type(buffer).__name__}")
        check_id(buffer.id, "buffer")
        if buffer.id in buffer_ids:
            raise ValueError(f"buffer id {buffer.id!r} is used twice: buffer ids must be unique (3.5.2)")
        buffer_ids.add(buffer.id)
        check_resolution(buffer.resolution, f"buffer {buffer.id!r}")
        regions = buffer.regions
        if isinstance(regions, MpcdiRegion) or not isinstance(regions, Sequence) or not regions:
            raise ValueError(f"buffer {buffer.id!r} needs a non-empty list of regions")
        if profile == "sl" and len(regions) != 1:
            raise ValueError(f"buffer {buffer.id!r} has {len(regions)} regions: profile 'sl' allows one per buffer "
                             "(3.5.2)")
        for region in regions:
            item = _prepare_region(region, buffer, profile)
            if region.id in region_ids:
                raise ValueError(f"region id {region.id!r} is used twice: region ids must be unique in the file")
            region_ids.add(region.id)
            prepared.append(item)
    if profile == "sl" and len({item.distortion is None for item in prepared}) > 1:
        raise ValueError("some regions have a distortion map and some not: at geometry level 2 every 'sl' "
                         "fileset holds one (3.5.2)")
    return list(buffers), prepared


def _level_1_0(profile: str, prepared: list[_Prepared]) -> int:
    """MPCDI 1.0's single level (figure 3-2): 1 or 3 by the geometry, one more with beta maps."""
    beta = any(item.beta is not None for item in prepared)
    return (1 if _geometry_level(profile, prepared) == 1 else 3) + (1 if beta else 0)


def _geometry_level(profile: str, prepared: list[_Prepared]) -> int:
    if profile == "sl":
        return 2 if prepared[0].distortion is not None else 1
    coarse = all(item.warp.shape[0] <= LEVEL_1_WARP_GRID and item.warp.shape[1] <= LEVEL_1_WARP_GRID
                 for item in prepared)
    return 1 if coarse else 2


def _member_names(prepared: list[_Prepared]) -> dict[str, RegionFiles]:
    """File names at the container's root (no folders, 3.3) from the region ids, unique even on a
    case-insensitive file system."""
    names, used = {}, set()
    for item in prepared:
        stem = re.sub(r"[^A-Za-z0-9_-]+", "_", item.region.id).strip("_") or "region"
        candidate, n = stem, 1
        while candidate.lower() in used:
            n += 1
            candidate = f"{stem}_{n}"
        used.add(candidate.lower())
        names[item.region.id] = RegionFiles(
            warp=f"{candidate}_warp.pfm", alpha=f"{candidate}_alpha.png",
            beta=None if item.beta is None else f"{candidate}_beta.png",
            distortion=None if item.distortion is None else f"{candidate}_distortion.pfm")
    return names


def _zip_bytes(members: list[tuple[str, bytes]], date: dt.datetime) -> bytes:
    stamp = max(date.timetuple()[:6], (1980, 1, 1, 0, 0, 0))  # the ZIP format starts in 1980
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as archive:
        for name, data in members:
            info = zipfile.ZipInfo(name, date_time=stamp)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, data)
    return out.getvalue()


def _write_error(exc: OSError, target) -> OSError:
    error = OSError(f"cannot write the MPCDI package {target}: {exc.strerror or exc}")
    error.errno = exc.errno
    return error


def _check_options(profile, path, geometric_unit, origin_of_3d_data, interpolation, bit_depth, date):
    if not isinstance(profile, str) or profile not in PROFILES:
        raise ValueError(f"unknown MPCDI profile {profile!r}: this writer writes '2d' or 'sl'")
    if Path(path).suffix.lower() != EXTENSION:
        raise ValueError(f"an MPCDI package's name ends in {EXTENSION} (3.1), got {Path(path).name!r}")
    if geometric_unit not in GEOMETRIC_UNITS:
        raise ValueError(f"geometric unit {geometric_unit!r} is not one of {', '.join(GEOMETRIC_UNITS)}")
    if origin_of_3d_data not in ORIGINS_OF_3D_DATA:
        raise ValueError(f"origin of 3D data {origin_of_3d_data!r} is not one of {', '.join(ORIGINS_OF_3D_DATA)}")
    if profile == "sl" and origin_of_3d_data == "idealEyePoint":
        raise ValueError("profile 'sl' cannot have its 3D data's origin at idealEyePoint (3.5.2)")
    if profile == "2d" and (geometric_unit, origin_of_3d_data) != ("unknown", "unknown"):
        raise ValueError("profile '2d' holds normalised 2D coordinates: its geometric unit and origin are 'unknown'")
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation {interpolation!r} is not one of {', '.join(INTERPOLATIONS)}")
    if isinstance(bit_depth, bool) or not isinstance(bit_depth, int) or bit_depth not in BIT_DEPTHS:
        raise ValueError(f"blend map bit depth must be 8 or 16, got {bit_depth!r}")
    if not isinstance(date, dt.datetime):
        raise ValueError(f"date must be a datetime, got {type(date).__name__}")


def write_mpcdi(path, profile: str, buffers: Sequence[MpcdiBuffer], *, geometric_unit: str | None = None,
                origin_of_3d_data: str = "unknown", interpolation: str = "linear", bit_depth: int | None = None,
                date: dt.datetime | None = None, comment: str | None = None, version: str = "2.0") -> Path:
    """Write the MPCDI package of `buffers` to `path` (a .mpcdi file) and return its path.

    geometric_unit and origin_of_3d_data describe 'sl' 3D data (default metres, Blender's unit, and
    'unknown' origin); '2d' data has neither ('unknown'). interpolation: how a reader fills between warp
    texels (2.7). bit_depth: the PNG blend maps' 8 or 16 bits (default 16 for 2.0, 8 for 1.0). date: the
    descriptor's date (default now). version: "2.0" or "1.0".
    comment: an XML comment written before the root of mpcdi.xml (e.g. the 3D data's axis convention).
    Raises ValueError (one line) for input the spec does not allow, OSError (one line) when the file
    cannot be written; in both cases nothing is left at `path` but what was there before.
    """
    if geometric_unit is None:
        geometric_unit = "m" if profile == "sl" else "unknown"
    if version not in VERSIONS:
        raise ValueError(f"MPCDI version must be one of {', '.join(VERSIONS)}, got {version!r}")
    if bit_depth is None:
        bit_depth = 8 if version == "1.0" else 16
    date = dt.datetime.now().replace(microsecond=0) if date is None else date
    _check_options(profile, path, geometric_unit, origin_of_3d_data, interpolation, bit_depth, date)
    buffers, prepared = _prepare(profile, buffers)
    color_level = 2 if any(item.beta is not None for item in prepared) else 1
    facts = PackageFacts(profile=profile, geometry_level=_geometry_level(profile, prepared), color_level=color_level,
                         date=date, geometric_unit=geometric_unit, origin_of_3d_data=origin_of_3d_data,
                         interpolation=interpolation, bit_depth=bit_depth, comment=comment, version=version,
                         level=_level_1_0(profile, prepared))
    scale = "-1.000000" if version == "1.0" else "-1.0"
    names = _member_names(prepared)
    members = [(DESCRIPTOR, descriptor_xml(buffers, names, facts))]
    for item in prepared:
        files = names[item.region.id]
        what = f"region {item.region.id!r}"
        members.append((files.warp, encode_pfm(item.warp, scale)))
        members.append((files.alpha, encode_png(encode_alpha(item.alpha, float(item.region.gamma), bit_depth),
                                                bit_depth, f"{what} alpha")))
        if item.beta is not None:
            members.append((files.beta, encode_png(_encode_linear(item.beta, bit_depth), bit_depth, f"{what} beta")))
        if item.distortion is not None:
            members.append((files.distortion, encode_pfm(item.distortion, scale)))
    data = _zip_bytes(members, date)
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _write_error(exc, target) from exc
    atomic.commit([(target, data)], error=_write_error)
    return target
