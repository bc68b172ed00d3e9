# SPDX-License-Identifier: GPL-3.0-or-later
"""The XML descriptor of an MPCDI package (mpcdi.xml): VESA MPCDI 2.0 sections 3.5.2 and 3.5.3, or MPCDI 1.0
(version 1a, 2013, the same sections) where PackageFacts.version is "1.0".

Built from already checked objects (mpcdi_model) and the member names mpcdi.py chose; it checks
nothing itself. Numbers are written with repr(), the shortest text that reads back to the same double.

Spellings: MPCDI's tag and attribute names are case-insensitive (3.5.2), and readers differ. The 2.0
text spells xResolution, xSize, originOf3DData and puts geometry and color levels on the root; the
VESA reference library (Scalable Display's MPCDI 1.0 reader, which other tools build on) looks up
Xresolution, xsize, originof3DData and a root `level` case-sensitively, and fails without them. Where
the two differ we write both, with equal values, so either kind of reader finds what it looks for.

MPCDI 1.0 (Watchout 6, the VESA reference reader, which refuses 2.0) differs: version="1.0" and one integer
`level` (1-4: the warp's resolution and whether there are beta maps or distortion maps, figure 3-2) on the root,
no geometry and color attributes; Xresolution / Yresolution and xsize / ysize only (3.5.3's spelling); no
`color` element in a region (1.0 has none: a '2d' region holds no tags, an 'sl' one its frustum and
coordinate frame). The fileset is the same; originOf3DData is written in both spellings, as for 2.0.
"""
from __future__ import annotations

import datetime as dt
import xml.etree.ElementTree as ET
from dataclasses import dataclass

from .mpcdi_model import MpcdiBuffer, MpcdiCoordinateFrame, MpcdiFrustum, MpcdiRegion

VERSION = "2.0"
VERSIONS = ("2.0", "1.0")
DECLARATION = '<?xml version="1.0" encoding="utf-8"?>\n'  # required verbatim at the start (3.5.2)
DATE_FORMAT = "%Y-%m-%d %H:%M:%S"  # ISO 8601 as the spec writes it (3.5.2)
COMPONENT_DEPTH = 1  # single-channel alpha and beta: color levels 1 and 2 (table 3-3)

# (the 2.0 spelling, the reference library's spelling)
RESOLUTION_ATTRIBUTES = (("xResolution", "Xresolution"), ("yResolution", "Yresolution"))
SIZE_ATTRIBUTES = (("xSize", "xsize"), ("ySize", "ysize"))
ORIGIN_TAGS = ("originOf3DData", "originof3DData")
LEGACY_LEVEL_ATTRIBUTE = "level"  # MPCDI 1.0's single level; we give it the geometry level


@dataclass(frozen=True)
class RegionFiles:
    """The container's member names for one region's fileset (None: not in the package)."""
    warp: str
    alpha: str
    beta: str | None
    distortion: str | None


@dataclass(frozen=True)
class PackageFacts:
    """What the descriptor says about the package as a whole."""
    profile: str
    geometry_level: int
    color_level: int
    date: dt.datetime
    geometric_unit: str
    origin_of_3d_data: str
    interpolation: str
    bit_depth: int
    comment: str | None = None  # written as an XML comment before the root (e.g. the 3D data's axes)
    version: str = VERSION
    level: int = 1  # MPCDI 1.0's single level (figure 3-2)


def _number(value) -> str:
    return repr(float(value))


def _text(parent: ET.Element, tag: str, value) -> ET.Element:
    element = ET.SubElement(parent, tag)
    element.text = value if isinstance(value, str) else _number(value) if isinstance(value, float) else str(value)
    return element


def _set_both(element: ET.Element, names: tuple[str, str], value: str) -> None:
    for name in names:
        element.set(name, value)


def _frustum(parent: ET.Element, frustum: MpcdiFrustum) -> None:
    element = ET.SubElement(parent, "frustum")
    for tag, value in (("yaw", frustum.yaw), ("pitch", frustum.pitch), ("roll", frustum.roll),
                       ("rightAngle", frustum.right_angle), ("leftAngle", frustum.left_angle),
                       ("upAngle", frustum.up_angle), ("downAngle", frustum.down_angle)):
        _text(element, tag, float(value))


def _coordinate_frame(parent: ET.Element, frame: MpcdiCoordinateFrame) -> None:
    element = ET.SubElement(parent, "coordinateFrame")
    for prefix, vector in (("pos", frame.position), ("yaw", frame.yaw_axis), ("pitch", frame.pitch_axis),
                           ("roll", frame.roll_axis)):
        for axis, value in zip("xyz", vector):
            _text(element, prefix + axis, float(value))


def _color(parent: ET.Element, region: MpcdiRegion) -> None:
    """Color levels 1-2: a single decode and encode gamma (2.5.1, table 3-3); the spec's best practice
    sets encode to the decode gamma when the encode stage is not used (2.5.1.3)."""
    element = ET.SubElement(parent, "color")
    gamma = _number(region.signal_gamma)
    ET.SubElement(element, "decode", {"type": "gamma", "gamma": gamma})
    ET.SubElement(element, "correct", {"type": "none"})
    ET.SubElement(element, "encode", {"type": "gamma", "gamma": gamma})


def _spellings(names: tuple[str, str], version: str) -> tuple[str, ...]:
    return names[1:] if version == "1.0" else names  # 1.0: 3.5.3's spelling only


def _region(parent: ET.Element, region: MpcdiRegion, version: str) -> None:
    element = ET.SubElement(parent, "region", {"id": region.id})
    for names, value in zip(RESOLUTION_ATTRIBUTES, region.resolution):
        _set_both(element, _spellings(names, version), str(int(value)))
    element.set("x", _number(region.x))
    element.set("y", _number(region.y))
    for names, value in zip(SIZE_ATTRIBUTES, (region.xsize, region.ysize)):
        _set_both(element, _spellings(names, version), _number(value))
    if region.frustum is not None:
        _frustum(element, region.frustum)
    if region.coordinate_frame is not None:
        _coordinate_frame(element, region.coordinate_frame)
    if version != "1.0":  # 1.0 has no colour element
        _color(element, region)


def _fileset(parent: ET.Element, region: MpcdiRegion, files: RegionFiles, facts: PackageFacts) -> None:
    fileset = ET.SubElement(parent, "fileset", {"region": region.id})
    warp = ET.SubElement(fileset, "geometryWarpFile")
    _text(warp, "geometricUnit", facts.geometric_unit)
    for tag in ORIGIN_TAGS:
        _text(warp, tag, facts.origin_of_3d_data)
    _text(warp, "path", files.warp)
    _text(warp, "interpolation", facts.interpolation)
    alpha = ET.SubElement(fileset, "alphaMap")
    _text(alpha, "bitDepth", facts.bit_depth)
    _text(alpha, "componentDepth", COMPONENT_DEPTH)
    _text(alpha, "gammaEmbedded", float(region.gamma))
    _text(alpha, "path", files.alpha)
    if files.beta is not None:
        beta = ET.SubElement(fileset, "betaMap")
        _text(beta, "bitDepth", facts.bit_depth)
        _text(beta, "componentDepth", COMPONENT_DEPTH)
        _text(beta, "path", files.beta)
    if files.distortion is not None:
        distortion = ET.SubElement(fileset, "distortionMap")
        _text(distortion, "path", files.distortion)


def descriptor_xml(buffers: list[MpcdiBuffer], files: dict[str, RegionFiles], facts: PackageFacts) -> bytes:
    """mpcdi.xml's bytes (UTF-8): the MPCDI root, one display with every buffer and region, one files
    tag with a fileset per region (3.5.3's layout and order). `files` maps region id to its members."""
    if facts.version == "1.0":
        root = ET.Element("MPCDI", {"profile": facts.profile, LEGACY_LEVEL_ATTRIBUTE: str(facts.level),
                                    "date": facts.date.strftime(DATE_FORMAT), "version": "1.0"})
    else:
        root = ET.Element("MPCDI", {"profile": facts.profile, "geometry": str(facts.geometry_level),
                                    "color": str(facts.color_level), "date": facts.date.strftime(DATE_FORMAT),
                                    "version": VERSION, LEGACY_LEVEL_ATTRIBUTE: str(facts.geometry_level)})
    display = ET.SubElement(root, "display")
    for buffer in buffers:
        element = ET.SubElement(display, "buffer", {"id": buffer.id})
        for names, value in zip(RESOLUTION_ATTRIBUTES, buffer.resolution):
            _set_both(element, _spellings(names, facts.version), str(int(value)))
        for region in buffer.regions:
            _region(element, region, facts.version)
    files_element = ET.SubElement(root, "files")
    for buffer in buffers:
        for region in buffer.regions:
            _fileset(files_element, region, files[region.id], facts)
    ET.indent(root, space="  ")
    comment = ""
    if facts.comment:
        comment = "<!-- " + " ".join(str(facts.comment).replace("--", "- -").split()) + " -->\n"
    return (DECLARATION + comment + ET.tostring(root, encoding="unicode") + "\n").encode("utf-8")
