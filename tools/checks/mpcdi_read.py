# SPDX-License-Identifier: GPL-3.0-or-later
"""A strict reader of MPCDI 2.0 packages, written from the spec (VESA MPCDI 2.0, 19 May 2015).

It checks what the spec requires of any package, not only what our writer makes: the container
(3.3, 3.5.2), the descriptor's structure per profile and level (3.5.2), and that every file a fileset
names is in the container. Tag and attribute names are matched case-insensitively (3.5.2); two
spellings of one name must agree. It is the tests' independent view of what mpcdi.py writes.

A data file never runs code: the XML goes through xml.etree with any DOCTYPE refused (no entities to
expand), and the ZIP's members are size-checked before they are read.
"""
from __future__ import annotations

import datetime as dt
import re
import struct
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ...lapig_core.export.mpcdi_model import GEOMETRIC_UNITS, INTERPOLATIONS, ORIGINS_OF_3D_DATA, MpcdiCoordinateFrame, MpcdiFrustum
from ...lapig_core.export.pfm import decode_pfm

ALL_PROFILES = ("2d", "3d", "a3", "sl")  # table 3-2
_MAX_MEMBERS = 10_000
_MAX_MEMBER_BYTES = 1 << 30
_MAX_TOTAL_BYTES = 4 << 30
_DECLARATION = b'<?xml version="1.0" encoding="utf-8"?>'  # 3.5.2
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_COLOR_TYPE = {1: 0, 3: 2}  # componentDepth -> PNG colour type (gray, RGB)
_DATE_PATTERN = re.compile(r"\d{4}-\d{2}-\d{2} \d{2}:\d{2}:\d{2}")


@dataclass(frozen=True)
class WarpFile:
    path: str
    geometric_unit: str | None
    origin_of_3d_data: str | None
    interpolation: str | None


@dataclass(frozen=True)
class BlendMapFile:
    path: str
    bit_depth: int
    component_depth: int
    gamma_embedded: float | None  # alpha maps only


@dataclass(frozen=True)
class ReadRegion:
    id: str
    buffer_id: str
    resolution: tuple[int, int]
    x: float
    y: float
    xsize: float
    ysize: float
    frustum: MpcdiFrustum | None
    coordinate_frame: MpcdiCoordinateFrame | None
    decode: dict
    encode: dict
    warp: WarpFile
    alpha: BlendMapFile
    beta: BlendMapFile | None
    distortion: str | None


@dataclass(frozen=True)
class ReadBuffer:
    id: str
    resolution: tuple[int, int] | None
    regions: tuple[ReadRegion, ...]


# ---- case-insensitive lookups (3.5.2: tag and attribute names are case-insensitive) ----

def _same(a: str, b: str) -> bool:
    return a.lower() == b.lower()


def _attribute(element: ET.Element, name: str, required: bool = True) -> str | None:
    values = {value for key, value in element.attrib.items() if _same(key, name)}
    if len(values) > 1:
        raise ValueError(f"<{element.tag}> spells {name} more than once with different values: {sorted(values)}")
    if not values:
        if required:
            raise ValueError(f"<{element.tag}> lacks the {name} attribute")
        return None
    return values.pop()


def _children(element: ET.Element, tag: str) -> list[ET.Element]:
    return [child for child in element if _same(child.tag, tag)]


def _child(element: ET.Element, tag: str, required: bool = True) -> ET.Element | None:
    found = _children(element, tag)
    if not found:
        if required:
            raise ValueError(f"<{element.tag}> lacks a <{tag}> tag")
        return None
    differing = len({(c.text or "").strip() for c in found}) > 1 or any(len(c) for c in found[1:])
    if len(found) > 1 and differing:  # one tag spelt two ways is fine while both say the same
        raise ValueError(f"<{element.tag}> holds more than one differing <{tag}>")
    return found[0]


def _text(element: ET.Element, tag: str, required: bool = True) -> str | None:
    child = _child(element, tag, required)
    return None if child is None else (child.text or "").strip()


def _int(text: str | None, what: str) -> int:
    try:
        return int(text)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be an integer, got {text!r}") from None


def _float(text: str | None, what: str) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, got {text!r}") from None


# ---- the container ----

def _members(path: Path) -> dict[str, bytes]:
    """Every member's bytes; root-level files only (3.3), sizes bounded before reading."""
    try:
        archive = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise ValueError(f"{path} is not a ZIP file (an MPCDI package is one, 3.3)") from None
    with archive:
        infos = archive.infolist()
        if len(infos) > _MAX_MEMBERS:
            raise ValueError(f"{path} holds {len(infos)} files, more than {_MAX_MEMBERS}")
        if sum(info.file_size for info in infos) > _MAX_TOTAL_BYTES:
            raise ValueError(f"{path} unpacks to more than {_MAX_TOTAL_BYTES} bytes")
        members: dict[str, bytes] = {}
        for info in infos:
            name = info.filename
            if "/" in name or "\\" in name or info.is_dir() or name in (".", ".."):
                raise ValueError(f"{path} holds {name!r}: files sit at the container's root, no folders (3.3)")
            if name in members:
                raise ValueError(f"{path} holds {name!r} twice")
            if info.file_size > _MAX_MEMBER_BYTES:
                raise ValueError(f"{path}: {name!r} unpacks to {info.file_size} bytes")
            members[name] = archive.read(info)
    return members


def _descriptor_root(data: bytes) -> ET.Element:
    if not data[:len(_DECLARATION)].lower() == _DECLARATION:  # encoding names are case-insensitive
        raise ValueError('mpcdi.xml must begin with <?xml version="1.0" encoding="utf-8"?> (3.5.2)')
    if b"<!DOCTYPE" in data.upper() or b"<!ENTITY" in data.upper():
        raise ValueError("mpcdi.xml declares a DOCTYPE or entities: refused")
    try:
        return ET.fromstring(data.decode("utf-8"))
    except (UnicodeDecodeError, ET.ParseError) as exc:
        raise ValueError(f"mpcdi.xml is not well-formed UTF-8 XML: {exc}") from None


# ---- the descriptor ----

def _frustum(element: ET.Element) -> MpcdiFrustum:
    names = ("yaw", "pitch", "roll", "rightAngle", "leftAngle", "upAngle", "downAngle")
    values = [_float(_text(element, name), f"frustum {name}") for name in names]
    return MpcdiFrustum(*values)


def _coordinate_frame(element: ET.Element) -> MpcdiCoordinateFrame:
    def vector(prefix):
        return tuple(_float(_text(element, prefix + axis), f"coordinateFrame {prefix}{axis}") for axis in "xyz")
    return MpcdiCoordinateFrame(vector("pos"), vector("yaw"), vector("pitch"), vector("roll"))


def _color_stage(color: ET.Element, tag: str) -> dict:
    element = _child(color, tag)
    stage = {"type": _attribute(element, "type")}
    gamma = _attribute(element, "gamma", required=False)
    if stage["type"] == "gamma" and gamma is None:
        raise ValueError(f"<{tag} type=\"gamma\"> lacks its gamma attribute (3.5.2)")
    stage["gamma"] = 1.0 if gamma is None else _float(gamma, f"{tag} gamma")
    return stage


def _blend_map(element: ET.Element, what: str, alpha: bool) -> BlendMapFile:
    bit_depth = _int(_text(element, "bitDepth"), f"{what} bitDepth")
    component_depth = _int(_text(element, "componentDepth"), f"{what} componentDepth")
    if bit_depth not in (8, 16, 32) or component_depth not in (1, 3):
        raise ValueError(f"{what}: bitDepth {bit_depth} / componentDepth {component_depth} not allowed (3.5.2)")
    gamma = _float(_text(element, "gammaEmbedded"), f"{what} gammaEmbedded") if alpha else None
    return BlendMapFile(_text(element, "path"), bit_depth, component_depth, gamma)


def _warp_file(element: ET.Element, profile: str) -> WarpFile:
    needs_3d_facts = profile in ("a3", "sl")
    unit = _text(element, "geometricUnit", needs_3d_facts)
    origin = _text(element, "originOf3DData", needs_3d_facts)
    interpolation = _text(element, "interpolation", False)
    if unit is not None and unit not in GEOMETRIC_UNITS:
        raise ValueError(f"geometricUnit {unit!r} is not one of {GEOMETRIC_UNITS}")
    if origin is not None and origin not in ORIGINS_OF_3D_DATA:
        raise ValueError(f"originOf3DData {origin!r} is not one of {ORIGINS_OF_3D_DATA}")
    if profile == "sl" and origin == "idealEyePoint":
        raise ValueError("profile 'sl' cannot have originOf3DData idealEyePoint (3.5.2)")
    if interpolation is not None and interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation {interpolation!r} is not one of {INTERPOLATIONS}")
    return WarpFile(_text(element, "path"), unit, origin, interpolation)


class MpcdiPackage:
    """A read and checked package: its root facts, buffers and regions, and its files' contents."""

    def __init__(self, path):
        self.path = Path(path)
        self.members = _members(self.path)
        descriptors = [name for name in self.members if _same(name, "mpcdi.xml")]
        if descriptors != ["mpcdi.xml"]:
            raise ValueError(f"{self.path} must hold exactly one mpcdi.xml, it holds {descriptors} (3.5.2)")
        self.descriptor = self.members["mpcdi.xml"]
        self.root = _descriptor_root(self.descriptor)
        self._read_root()
        self.buffers = self._read_display()
        self._read_files()

    def _read_root(self) -> None:
        root = self.root
        if not _same(root.tag, "MPCDI"):
            raise ValueError(f"the root tag is <{root.tag}>, not <MPCDI>")
        self.profile = _attribute(root, "profile")
        self.version = _attribute(root, "version")
        self.geometry_level = _int(_attribute(root, "geometry"), "geometry level")
        self.color_level = _int(_attribute(root, "color"), "color level")
        self.date = _attribute(root, "date")
        if self.profile not in ALL_PROFILES:
            raise ValueError(f"profile {self.profile!r} is not one of {ALL_PROFILES} (table 3-2)")
        if self.version != "2.0":
            raise ValueError(f"version {self.version!r} is not 2.0")
        if self.geometry_level not in (1, 2) or self.color_level not in (1, 2, 3, 4, 5):
            raise ValueError(f"geometry level {self.geometry_level} / color level {self.color_level} out of range")
        if not _DATE_PATTERN.fullmatch(self.date):
            raise ValueError(f"date {self.date!r} is not yyyy-MM-dd HH:mm:ss (3.5.2)")
        dt.datetime.strptime(self.date, "%Y-%m-%d %H:%M:%S")
        tags = [child.tag.lower() for child in root]
        if tags.count("display") != 1 or tags.count("files") != 1 or set(tags) - {"display", "files", "extensionset"}:
            raise ValueError(f"<MPCDI> must hold one <display>, one <files> and optionally <extensionSet>, got {tags}")

    def _read_display(self) -> tuple[ReadBuffer, ...]:
        display = _child(self.root, "display")
        if not len(display) or any(not _same(child.tag, "buffer") for child in display):
            raise ValueError("<display> must hold one or more <buffer> tags and nothing else (3.5.2)")
        buffers, buffer_ids, region_ids = [], set(), set()
        for element in display:
            buffer_id = _attribute(element, "id")
            if buffer_id in buffer_ids:
                raise ValueError(f"buffer id {buffer_id!r} is not unique")
            buffer_ids.add(buffer_id)
            width, height = (_attribute(element, name, required=False) for name in ("xResolution", "yResolution"))
            resolution = None if width is None else (_int(width, "buffer xResolution"),
                                                     _int(height, "buffer yResolution"))
            regions = _children(element, "region")
            if not regions or len(regions) != len(element):
                raise ValueError(f"buffer {buffer_id!r} must hold one or more <region> tags (3.5.2)")
            if self.profile == "sl" and len(regions) != 1:
                raise ValueError(f"buffer {buffer_id!r}: profile 'sl' allows one region per buffer (3.5.2)")
            read = tuple(self._read_region(region, buffer_id) for region in regions)
            for region in read:
                if region["id"] in region_ids:
                    raise ValueError(f"region id {region['id']!r} is not unique")
                region_ids.add(region["id"])
            buffers.append(ReadBuffer(buffer_id, resolution, read))
        return tuple(buffers)

    def _read_region(self, element: ET.Element, buffer_id: str) -> dict:
        """The region's own facts; its files are added once the filesets are read."""
        region_id = _attribute(element, "id")
        what = f"region {region_id!r}"
        attributes = {name: _float(_attribute(element, name), f"{what} {name}")
                      for name in ("x", "y", "xSize", "ySize")}
        resolution = (_int(_attribute(element, "xResolution"), f"{what} xResolution"),
                      _int(_attribute(element, "yResolution"), f"{what} yResolution"))
        frustum_element = _child(element, "frustum", required=self.profile in ("3d", "sl"))
        frame_element = _child(element, "coordinateFrame", required=self.profile == "sl")
        if self.profile in ("2d", "a3") and (frustum_element is not None or frame_element is not None):
            raise ValueError(f"{what}: profile {self.profile!r} has no frustum or coordinateFrame (3.5.2)")
        color = _child(element, "color")
        return dict(id=region_id, buffer_id=buffer_id, resolution=resolution, x=attributes["x"], y=attributes["y"],
                    xsize=attributes["xSize"], ysize=attributes["ySize"],
                    frustum=None if frustum_element is None else _frustum(frustum_element),
                    coordinate_frame=None if frame_element is None else _coordinate_frame(frame_element),
                    decode=_color_stage(color, "decode"), encode=_color_stage(color, "encode"))

    def _read_files(self) -> None:
        files = _child(self.root, "files")
        if not len(files) or any(not _same(child.tag, "fileset") for child in files):
            raise ValueError("<files> must hold one or more <fileset> tags and nothing else (3.5.2)")
        filesets = {}
        for fileset in files:
            region_id = _attribute(fileset, "region")
            if region_id in filesets:
                raise ValueError(f"region {region_id!r} has more than one fileset")
            filesets[region_id] = fileset
        known = {region["id"] for buffer in self.buffers for region in buffer.regions}
        if set(filesets) != known:
            raise ValueError(f"filesets name regions {sorted(filesets)}, the display has {sorted(known)}")
        self.buffers = tuple(ReadBuffer(buffer.id, buffer.resolution,
                                        tuple(self._with_files(region, filesets[region["id"]])
                                              for region in buffer.regions))
                             for buffer in self.buffers)
        self.regions = {region.id: region for buffer in self.buffers for region in buffer.regions}

    def _with_files(self, region: dict, fileset: ET.Element) -> ReadRegion:
        what = f"region {region['id']!r}"
        warp = _warp_file(_child(fileset, "geometryWarpFile"), self.profile)
        alpha = _blend_map(_child(fileset, "alphaMap"), f"{what} alphaMap", alpha=True)
        beta_element = _child(fileset, "betaMap", required=self.color_level > 2)
        beta = None if beta_element is None else _blend_map(beta_element, f"{what} betaMap", alpha=False)
        needs_distortion = self.profile == "sl" and self.geometry_level >= 2  # 3.5.2
        distortion_element = _child(fileset, "distortionMap", required=needs_distortion)
        distortion = None if distortion_element is None else _text(distortion_element, "path")
        for path in (warp.path, alpha.path, beta and beta.path, distortion):
            if path is not None and path not in self.members:
                raise ValueError(f"{what}: {path!r} is not in the container")
        return ReadRegion(warp=warp, alpha=alpha, beta=beta, distortion=distortion, **region)

    # ---- the files ----

    def warp(self, region_id: str) -> np.ndarray:
        """The geometry warp as stored: (h, w, 3) float32, row 0 at the top (3.6.1: three components)."""
        grid = decode_pfm(self.members[self.regions[region_id].warp.path])
        if grid.ndim != 3:
            raise ValueError(f"region {region_id!r}: a geometry warp is a three-component PFM (3.6.1)")
        return grid

    def distortion(self, region_id: str) -> np.ndarray:
        return decode_pfm(self.members[self.regions[region_id].distortion])

    def stored_map(self, region_id: str, kind: str) -> np.ndarray:
        """The alpha or beta map's integers as stored; its PNG header must agree with the descriptor."""
        entry = getattr(self.regions[region_id], kind)
        return read_png(self.members[entry.path], entry.bit_depth, entry.component_depth, f"{region_id} {kind}")

    def alpha(self, region_id: str) -> np.ndarray:
        """The linear alpha weights: (stored / max) ** gammaEmbedded (2.5.1.2.4's gamma definition)."""
        entry = self.regions[region_id].alpha
        stored = self.stored_map(region_id, "alpha").astype(np.float64)
        return (stored / ((1 << entry.bit_depth) - 1)) ** entry.gamma_embedded

    def beta(self, region_id: str) -> np.ndarray:
        entry = self.regions[region_id].beta
        return self.stored_map(region_id, "beta").astype(np.float64) / ((1 << entry.bit_depth) - 1)


def png_header(data: bytes) -> tuple[int, int, int, int]:
    """(width, height, bit depth, colour type) from a PNG's IHDR chunk."""
    if not data.startswith(_PNG_SIGNATURE) or data[12:16] != b"IHDR":
        raise ValueError("not a PNG file")
    width, height, bit_depth, color_type = struct.unpack(">IIBB", data[16:26])
    return width, height, bit_depth, color_type


def read_png(data: bytes, bit_depth: int, component_depth: int, what: str) -> np.ndarray:
    """A blend map's integers, after checking its header against the declared depths."""
    _, _, file_depth, color_type = png_header(data)
    if file_depth != bit_depth or color_type != _PNG_COLOR_TYPE.get(component_depth):
        raise ValueError(f"{what}: the PNG is {file_depth}-bit colour type {color_type}, the descriptor says "
                         f"{bit_depth}-bit with {component_depth} component(s)")
    pixels = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise ValueError(f"{what}: the PNG cannot be decoded")
    return pixels


def read_mpcdi(path) -> MpcdiPackage:
    """Read and check the package at `path`; ValueError (one line) says what the spec does not allow."""
    return MpcdiPackage(path)
