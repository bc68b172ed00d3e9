"""A validator of MPCDI 1.0 packages, written from the 1.0 (version 1a, 2013) text's element and attribute lists
(3.3, 3.5, 3.5.2, 3.5.3, 3.6) and the VESA reference reader's needs (NOTES.md 13), separate from the writer.

    problems(path) -> [one line per broken rule]   (empty: the package follows the rules checked here)

Names are checked case-sensitively in the reference reader's spelling (it matches them so), although the text
calls tags and attributes case-insensitive."""
import re
import struct
import xml.etree.ElementTree as ET
import zipfile

PROFILES = ("2d", "3d", "a3", "sl")
UNITS = ("mm", "cm", "dm", "m", "in", "ft", "yd", "unknown")
ORIGINS = ("centerOfMass", "idealEyePoint", "floorCenter", "unknown")
INTERPOLATIONS = ("linear", "keystone", "smooth", "unknown")
FRUSTUM = ("yaw", "pitch", "roll", "rightAngle", "leftAngle", "upAngle", "downAngle")
FRAME = tuple(p + a for p in ("pos", "yaw", "pitch", "roll") for a in "xyz")
ROOT_ATTRIBUTES = {"profile", "level", "date", "version"}
BUFFER_ATTRIBUTES = {"id", "Xresolution", "Yresolution"}
REGION_ATTRIBUTES = {"id", "x", "y", "xsize", "ysize", "Xresolution", "Yresolution"}
WARP_TAGS = {"path", "geometricUnit", "originOf3DData", "originof3DData", "interpolation"}
ALPHA_TAGS = {"path", "componentDepth", "bitDepth", "gammaEmbedded"}
BETA_TAGS = {"path", "componentDepth", "bitDepth"}


def _text(element, tag):
    child = element.find(tag)
    return None if child is None or child.text is None else child.text.strip()


def _pfm(data: bytes, what: str, out: list):
    match = re.match(rb"PF\n(\d+) (\d+)\n(-1\.000000)\n", data)
    if not match:
        out.append(f"{what}: the header is not 'PF\\n<w> <h>\\n-1.000000\\n' (3 channels, little-endian)")
        return None
    w, h = int(match.group(1)), int(match.group(2))
    if len(data) != match.end() + w * h * 12:
        out.append(f"{what}: {len(data) - match.end()} bytes of floats, {w}x{h}x3 need {w * h * 12}")
    if w < 2 or h < 2:
        out.append(f"{what}: a warp grid is at least 2x2 (3.6), got {w}x{h}")
    return w, h


def _png(data: bytes, what: str, out: list, depth: str, components: str):
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR":
        out.append(f"{what}: not a PNG")
        return
    bit_depth, colour_type = data[24], data[25]
    channels = {0: 1, 2: 3}.get(colour_type)
    if channels is None:
        out.append(f"{what}: PNG colour type {colour_type}: the reference reader takes grey or RGB")
    if str(bit_depth) != depth:
        out.append(f"{what}: the PNG is {bit_depth}-bit, bitDepth says {depth}")
    if channels is not None and str(channels) != components:
        out.append(f"{what}: the PNG has {channels} channel(s), componentDepth says {components}")
    if bit_depth != 8:
        out.append(f"{what}: {bit_depth}-bit PNG: the reference reader decodes 8-bit maps only")


def problems(path) -> list:
    out = []
    with zipfile.ZipFile(path) as archive:
        names = archive.namelist()
        if any("/" in n for n in names):
            out.append("the container has folders: every file is at its root (3.3)")
        if "mpcdi.xml" not in names:
            return out + ["no mpcdi.xml (3.5.2)"]
        xml = archive.read("mpcdi.xml")
        members = {n: archive.read(n) for n in names}
    if not xml.startswith(b'<?xml version="1.0" encoding="utf-8"?>'):
        out.append("mpcdi.xml does not begin with the XML declaration 3.5.2 gives")
    root = ET.fromstring(xml)
    if root.tag != "MPCDI":
        return out + [f"the root is {root.tag}, not MPCDI"]
    extra = set(root.attrib) - ROOT_ATTRIBUTES
    missing = ROOT_ATTRIBUTES - set(root.attrib)
    if missing or extra:
        out.append(f"MPCDI attributes: missing {sorted(missing)}, not in 1.0 {sorted(extra)}")
    if root.get("version") != "1.0":
        out.append(f"version is {root.get('version')!r}, not '1.0'")
    profile = root.get("profile")
    if profile not in PROFILES:
        out.append(f"profile {profile!r} is not one of {PROFILES}")
    level = root.get("level", "")
    if not level.isdigit() or not 1 <= int(level) <= 4:
        out.append(f"level {level!r} is not an integer from 1 to 4")
        level = "0"
    level = int(level)
    if not re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d", root.get("date", "")):
        out.append(f"date {root.get('date')!r} is not yyyy-MM-dd HH:mm:ss")
    if [c.tag for c in root if c.tag != "extensionSet"] != ["display", "files"]:
        out.append(f"MPCDI holds {[c.tag for c in root]}: one display, then one files (3.5.2)")
    display, files = root.find("display"), root.find("files")
    regions = {}
    for buffer in (display if display is not None else []):
        if buffer.tag != "buffer":
            out.append(f"display holds a {buffer.tag}: only buffers (3.5.2)")
            continue
        if set(buffer.attrib) - BUFFER_ATTRIBUTES or "id" not in buffer.attrib:
            out.append(f"buffer attributes {sorted(buffer.attrib)}: id, and optional Xresolution, Yresolution")
        inside = list(buffer)
        if not inside or any(r.tag != "region" for r in inside):
            out.append(f"buffer {buffer.get('id')!r} must hold one or more regions and nothing else")
        if profile in ("a3", "sl") and len(inside) != 1:
            out.append(f"buffer {buffer.get('id')!r}: profile {profile} allows one region per buffer")
        for region in inside:
            attrs = set(region.attrib)
            if attrs != REGION_ATTRIBUTES:
                out.append(f"region {region.get('id')!r}: attributes missing {sorted(REGION_ATTRIBUTES - attrs)}, "
                           f"not in 1.0 {sorted(attrs - REGION_ATTRIBUTES)}")
            rid = region.get("id")
            if rid in regions:
                out.append(f"region id {rid!r} used twice")
            regions[rid] = region
            try:
                x, y, xs, ys = (float(region.get(k)) for k in ("x", "y", "xsize", "ysize"))
                int(region.get("Xresolution")), int(region.get("Yresolution"))
                if not (0 <= x <= 1 and 0 <= y <= 1 and 0 < xs <= 1 and 0 < ys <= 1):
                    out.append(f"region {rid!r}: x, y, xsize, ysize outside the normalised buffer")
            except (TypeError, ValueError):
                out.append(f"region {rid!r}: x, y, xsize, ysize must be floats, the resolutions integers")
            tags = [c.tag for c in region]
            want = {"2d": [], "a3": [], "3d": ["frustum"], "sl": ["frustum", "coordinateFrame"]}.get(profile, [])
            if tags != want:
                out.append(f"region {rid!r} holds {tags}: profile {profile} wants {want} (3.5.2)")
            frustum, frame = region.find("frustum"), region.find("coordinateFrame")
            if frustum is not None and [c.tag for c in frustum] != list(FRUSTUM):
                out.append(f"region {rid!r}: frustum holds {[c.tag for c in frustum]}, not {FRUSTUM}")
            if frame is not None and [c.tag for c in frame] != list(FRAME):
                out.append(f"region {rid!r}: coordinateFrame holds {[c.tag for c in frame]}, not {FRAME}")
    filesets = list(files) if files is not None else []
    if not filesets or any(f.tag != "fileset" for f in filesets):
        out.append("files must hold one or more filesets and nothing else (3.5.2)")
    origins = set()
    for fileset in filesets:
        rid = fileset.get("region")
        what = f"fileset {rid!r}"
        if rid not in regions:
            out.append(f"{what} names no region")
        tags = [c.tag for c in fileset]
        need = ["geometryWarpFile", "alphaMap"] + (["betaMap"] if level in (2, 4) else [])
        if profile == "sl" and level in (3, 4):
            need.append("distortionMap")
        if sorted(tags) != sorted(need):
            out.append(f"{what} holds {tags}: level {level} of {profile} wants {need}")
        warp = fileset.find("geometryWarpFile")
        if warp is not None:
            tags = {c.tag for c in warp}
            if tags - WARP_TAGS:
                out.append(f"{what} geometryWarpFile: tags not in 1.0 {sorted(tags - WARP_TAGS)}")
            for tag in ("path", "geometricUnit", "interpolation", "originof3DData"):  # the reader needs each
                if _text(warp, tag) is None:
                    out.append(f"{what} geometryWarpFile has no {tag}")
            if _text(warp, "geometricUnit") not in UNITS:
                out.append(f"{what}: geometricUnit {_text(warp, 'geometricUnit')!r} not in {UNITS}")
            if _text(warp, "interpolation") not in INTERPOLATIONS:
                out.append(f"{what}: interpolation {_text(warp, 'interpolation')!r} not in {INTERPOLATIONS}")
            spellings = {_text(warp, t) for t in ("originOf3DData", "originof3DData") if _text(warp, t) is not None}
            if len(spellings) > 1 or not spellings <= set(ORIGINS):
                out.append(f"{what}: originOf3DData {sorted(spellings)} not one value of {ORIGINS}")
            origins |= spellings
            if profile == "sl" and "idealEyePoint" in spellings:
                out.append(f"{what}: profile sl cannot have its origin at idealEyePoint")
            path = _text(warp, "path")
            if path not in members:
                out.append(f"{what}: warp {path!r} is not in the container")
            else:
                size = _pfm(members[path], f"{what} warp", out)
                if size and profile == "2d" and level in (1, 2) and max(size) > 32:
                    out.append(f"{what}: a {size[0]}x{size[1]} warp grid is beyond level {level}'s 32x32")
        for tag, allowed in (("alphaMap", ALPHA_TAGS), ("betaMap", BETA_TAGS)):
            element = fileset.find(tag)
            if element is None:
                continue
            tags = {c.tag for c in element}
            if tags != allowed:
                out.append(f"{what} {tag}: tags missing {sorted(allowed - tags)}, not in 1.0 {sorted(tags - allowed)}")
            depth, components = _text(element, "bitDepth"), _text(element, "componentDepth")
            if depth not in ("8", "16", "32") or components not in ("1", "3"):
                out.append(f"{what} {tag}: bitDepth {depth!r} (8, 16, 32), componentDepth {components!r} (1, 3)")
            if tag == "alphaMap":
                try:
                    float(_text(element, "gammaEmbedded"))
                except (TypeError, ValueError):
                    out.append(f"{what} alphaMap: gammaEmbedded is not a float")
            path = _text(element, "path")
            if path not in members:
                out.append(f"{what} {tag}: {path!r} is not in the container")
            else:
                _png(members[path], f"{what} {tag}", out, depth, components)
        distortion = fileset.find("distortionMap")
        if distortion is not None and [c.tag for c in distortion] != ["path"]:
            out.append(f"{what} distortionMap holds {[c.tag for c in distortion]}: only a path (3.5.2)")
    if len(origins) > 1:
        out.append(f"originOf3DData differs between filesets: {sorted(origins)}")
    return out


def pfm_floats(data: bytes, count: int):
    """The first `count` floats after a 1.0 header (for a test's spot check)."""
    end = data.index(b"-1.000000\n") + len(b"-1.000000\n")
    return struct.unpack(f"<{count}f", data[end:end + 4 * count])
