# SPDX-License-Identifier: GPL-3.0-or-later
"""MPCDI 2.0 packages (VESA MPCDI 2.0, 19 May 2015), checked against the spec by our own reader.

Two projectors side by side, each its own buffer with one full region (2.1, 3.5.1): the left shows
u in [0, 0.64] of the content, the right u in [0.36, 1], one content step of 0.01 per pixel, so the
left's pixel i and the right's pixel i - 36 show the same content point in the 28-pixel overlap.
"""
import datetime as dt
import errno
import io
import os
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from lapig.lapig_core.common import atomic
from lapig.lapig_core.export.mpcdi import (MpcdiBuffer, MpcdiCoordinateFrame, MpcdiFrustum, MpcdiRegion,
                                           encode_alpha, write_mpcdi)
from lapig.tools.checks.mpcdi_read import png_header, read_mpcdi
from lapig.lapig_core.export.pfm import decode_pfm, encode_pfm

W, H = 64, 48
STEP = 0.01  # content u per projector pixel
STARTS = {"left": 0.0, "right": 0.36}
OVERLAP = (0.36, 0.64)
DATE = dt.datetime(2025, 3, 4, 5, 6, 7)
GAMMA = 2.2


def _u(start, columns=W):
    return start + STEP * (np.arange(columns) + 0.5) * (W / columns)


def _warp_2d(start, grid=(H, W)):
    """Per-texel (u, v) over the region (fill layout, 3.6): v upward as in OpenGL's UV (3.6.2)."""
    rows, cols = grid
    u = np.broadcast_to(_u(start, cols), (rows, cols))
    v = np.broadcast_to(1.0 - (np.arange(rows)[:, None] + 0.5) / rows, (rows, cols))
    return np.stack([u, v], axis=2).astype(np.float32)


def _weight(name, u):
    """Linear blend weights that sum to 1 across the overlap."""
    width = OVERLAP[1] - OVERLAP[0]
    ramp = (OVERLAP[1] - u) / width if name == "left" else (u - OVERLAP[0]) / width
    return np.clip(ramp, 0.0, 1.0)


def _alpha(name):
    return np.broadcast_to(_weight(name, _u(STARTS[name])), (H, W)).copy()


def _beta(name):
    """Black-level lift outside the overlap, where only one projector adds its black (2.4)."""
    return (0.02 * (1.0 - (_alpha(name) < 1.0))).astype(np.float64)


def _region_2d(name, grid=(H, W), with_beta=True, gamma=GAMMA, **changes):
    fields = dict(id=name, resolution=(W, H), x=0.0, y=0.0, xsize=1.0, ysize=1.0, warp=_warp_2d(STARTS[name], grid),
                  alpha=_alpha(name), beta=_beta(name) if with_beta else None, gamma=gamma)
    fields.update(changes)
    return MpcdiRegion(**fields)


def _buffers_2d(**region_changes):
    return [MpcdiBuffer(f"projector-{name}", (W, H), [_region_2d(name, **region_changes)]) for name in STARTS]


def _wall_points(start, grid=(12, 16)):
    """3D points of a flat wall 2 m wide and 1.5 m high at z = 0, metres; a few unknown texels."""
    warp2d = _warp_2d(start, grid)
    points = np.stack([warp2d[..., 0] * 2.0 - 1.0, warp2d[..., 1] * 1.5, np.zeros(grid, np.float32)], axis=2)
    points = points.astype(np.float32)
    points[0, 0] = np.nan
    return points


FRAMES = {"left": MpcdiCoordinateFrame((-0.5, 0.75, 3.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0)),
          "right": MpcdiCoordinateFrame((0.5, 0.75, 3.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))}


def _region_sl(name, distortion=True, **changes):
    fields = dict(id=name, resolution=(W, H), x=0.0, y=0.0, xsize=1.0, ysize=1.0, warp=_wall_points(STARTS[name]),
                  alpha=_alpha(name), beta=_beta(name), gamma=GAMMA,
                  frustum=MpcdiFrustum.from_pinhole(80.0, 80.0, 32.0, 30.0, (W, H),
                                                    yaw=-5.0 if name == "left" else 5.0),
                  coordinate_frame=FRAMES[name],
                  distortion=_warp_2d(0.0, (12, 16)) * np.float32(0.98) + np.float32(0.01) if distortion else None)
    fields.update(changes)
    return MpcdiRegion(**fields)


def _buffers_sl(**region_changes):
    return [MpcdiBuffer(f"projector-{name}", (W, H), [_region_sl(name, **region_changes)]) for name in STARTS]


def _same_bits(a, b):
    """Equal float32 arrays, NaN included, bit for bit."""
    a, b = np.asarray(a, np.float32), np.asarray(b, np.float32)
    return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))


def _stored_2d(warp):
    """The 3-channel grid the file holds for a 2-channel warp: error NaN (not calculated), 3.6.2."""
    return np.concatenate([warp, np.full(warp.shape[:2] + (1,), np.nan, np.float32)], axis=2)


def _root(package):
    return ET.fromstring(package.descriptor)


def _one_line(exc_info):
    message = str(exc_info.value)
    assert message and "\n" not in message, message
    return message


# ---- PFM (3.6.1: netpbm's format) ----

def test_pfm_round_trips_exactly_with_the_bottom_row_first_little_endian():
    rng = np.random.default_rng(0)
    rgb = (rng.standard_normal((5, 7, 3)) * 1e3).astype(np.float32)
    rgb[1, 2] = [np.nan, -np.inf, np.float32(1e-42)]  # NaN, infinity and a denormal survive
    data = encode_pfm(rgb)
    header = b"PF\n7 5\n-1.0\n"  # negative scale: little endian
    assert data.startswith(header) and len(data) == len(header) + 5 * 7 * 3 * 4
    first_row = np.frombuffer(data[len(header):len(header) + 7 * 12], "<f4").reshape(7, 3)
    assert _same_bits(first_row, rgb[-1])  # the file starts with the image's bottom row
    assert _same_bits(decode_pfm(data), rgb)

    gray = rng.random((3, 4)).astype(np.float32)
    data = encode_pfm(gray)
    assert data.startswith(b"Pf\n4 3\n-1.0\n")
    assert _same_bits(decode_pfm(data), gray)


def test_pfm_reads_big_endian_and_refuses_broken_files():
    rows = np.arange(12, dtype=np.float32).reshape(2, 2, 3)
    big = b"PF\n2 2\n1.0\n" + np.ascontiguousarray(rows[::-1], ">f4").tobytes()
    assert _same_bits(decode_pfm(big), rows)
    good = encode_pfm(rows)
    for broken in (b"P6\n2 2\n255\n", good[:-1], good + b"\0\0\0\0", b"PF\n2\n", b"PF\n2 2\n0\n" + good[12:]):
        with pytest.raises(ValueError) as exc:
            decode_pfm(broken)
        _one_line(exc)
    with pytest.raises(ValueError, match="shape"):
        encode_pfm(np.zeros((2, 2, 2), np.float32))


# ---- the 2d profile: two projectors ----

def test_two_projector_2d_package_follows_the_spec(tmp_path):
    path = write_mpcdi(tmp_path / "wall.mpcdi", "2d", _buffers_2d(), date=DATE)
    package = read_mpcdi(path)  # checks the container, the structure per profile and level, the paths

    # the container: one mpcdi.xml and every file at its root (3.3, 3.5.2)
    with zipfile.ZipFile(path) as archive:
        names = sorted(archive.namelist())
        assert all(info.compress_type == zipfile.ZIP_DEFLATED for info in archive.infolist())
    assert names == sorted(["mpcdi.xml"] + [f"{n}_{kind}" for n in STARTS
                                            for kind in ("warp.pfm", "alpha.png", "beta.png")])

    # the root (3.5.2): declaration, tag, profile, levels (table 3-2: per-pixel warp is level 2;
    # table 3-3: single-channel alpha and beta is color level 2), date, version
    assert package.descriptor.startswith(b'<?xml version="1.0" encoding="utf-8"?>')
    root = _root(package)
    assert root.tag == "MPCDI"
    assert root.attrib == {"profile": "2d", "geometry": "2", "color": "2", "date": "2025-03-04 05:06:07",
                           "version": "2.0", "level": "2"}
    assert (package.profile, package.version, package.geometry_level, package.color_level) == ("2d", "2.0", 2, 2)
    assert [child.tag for child in root] == ["display", "files"]

    # display: one buffer per projector, one full region each, ids and sizes (3.5.2)
    display = root.find("display")
    assert [b.get("id") for b in display] == ["projector-left", "projector-right"]
    for buffer_element, name in zip(display, STARTS):
        assert [c.tag for c in buffer_element] == ["region"]
        assert (buffer_element.get("xResolution"), buffer_element.get("yResolution")) == ("64", "48")
        assert (buffer_element.get("Xresolution"), buffer_element.get("Yresolution")) == ("64", "48")
        region = buffer_element.find("region")
        assert region.get("id") == name
        assert (region.get("xResolution"), region.get("yResolution")) == ("64", "48")
        sizes = [float(region.get(a)) for a in ("x", "y", "xSize", "ySize")]
        assert sizes == [0.0, 0.0, 1.0, 1.0] and all(0.0 <= s <= 1.0 for s in sizes)
        assert (region.get("xsize"), region.get("ysize")) == (region.get("xSize"), region.get("ySize"))
        assert region.find("frustum") is None and region.find("coordinateFrame") is None  # 2d has none
        color = region.find("color")  # a color tag with decode and encode for every region (3.5.2)
        assert color.find("decode").attrib == {"type": "gamma", "gamma": "2.2"}
        assert color.find("encode").attrib == {"type": "gamma", "gamma": "2.2"}

    # files: one fileset per region, every path in the container, attributes per 3.5.2
    filesets = root.find("files")
    assert [f.get("region") for f in filesets] == list(STARTS)
    for fileset in filesets:
        assert [c.tag for c in fileset] == ["geometryWarpFile", "alphaMap", "betaMap"]
        warp = fileset.find("geometryWarpFile")
        assert warp.findtext("path") in names and warp.findtext("path").endswith(".pfm")
        assert warp.findtext("interpolation") == "linear"
        assert warp.findtext("geometricUnit") == "unknown"
        assert warp.findtext("originOf3DData") == warp.findtext("originof3DData") == "unknown"
        alpha = fileset.find("alphaMap")
        assert alpha.findtext("path") in names and alpha.findtext("path").endswith(".png")
        assert (alpha.findtext("bitDepth"), alpha.findtext("componentDepth")) == ("16", "1")
        assert float(alpha.findtext("gammaEmbedded")) == GAMMA
        beta = fileset.find("betaMap")
        assert beta.findtext("path") in names and beta.find("gammaEmbedded") is None
        assert (beta.findtext("bitDepth"), beta.findtext("componentDepth")) == ("16", "1")

    for name in STARTS:
        region = package.regions[name]
        assert region.resolution == (W, H) and region.buffer_id == f"projector-{name}"
        # the warp round-trips bit for bit: (u, v) as given, the error channel NaN (3.6.2)
        assert _same_bits(package.warp(name), _stored_2d(_warp_2d(STARTS[name])))
        # alpha: a 16-bit grayscale PNG of the region's size, gamma embedded, decoding to the weights
        data = package.members[region.alpha.path]
        assert png_header(data) == (W, H, 16, 0)
        stored = package.stored_map(name, "alpha")
        assert stored.dtype == np.uint16 and stored.shape == (H, W)
        assert np.array_equal(stored, np.rint(65535 * _alpha(name) ** (1 / GAMMA)))
        assert stored.max() == 65535  # full weight outside the overlap
        decoded = package.alpha(name)
        assert 0.0 <= decoded.min() and decoded.max() == 1.0
        assert np.abs(decoded - _alpha(name)).max() < 1e-4
        # beta: 16-bit grayscale, linear, in [0, 1]
        assert png_header(package.members[region.beta.path]) == (W, H, 16, 0)
        beta = package.beta(name)
        assert 0.0 <= beta.min() and beta.max() <= 1.0
        assert np.abs(beta - _beta(name)).max() <= 0.5 / 65535 + 1e-12


@pytest.mark.parametrize("bit_depth, tolerance", [(16, 1e-3), (8, 0.02)])
def test_decoded_alphas_sum_to_one_across_the_overlap(tmp_path, bit_depth, tolerance):
    package = read_mpcdi(write_mpcdi(tmp_path / "blend.mpcdi", "2d", _buffers_2d(), bit_depth=bit_depth, date=DATE))
    left_u, right_u = package.warp("left")[0, :, 0], package.warp("right")[0, :, 0]
    left_alpha, right_alpha = package.alpha("left"), package.alpha("right")
    assert png_header(package.members[package.regions["left"].alpha.path])[2] == bit_depth
    sums = []
    for i in np.flatnonzero((left_u > OVERLAP[0]) & (left_u < OVERLAP[1])):
        j = int(np.argmin(np.abs(right_u - left_u[i])))  # the right pixel that shows the same content
        assert abs(right_u[j] - left_u[i]) < 1e-6
        sums.append(left_alpha[:, i] + right_alpha[:, j])
    sums = np.concatenate(sums)
    assert len(sums) == 28 * H
    assert np.abs(sums - 1.0).max() <= tolerance
    # the gamma matters: the stored values alone do not sum to 1
    raw = package.stored_map("left", "alpha")[:, 40] / (2 ** bit_depth - 1) + \
        package.stored_map("right", "alpha")[:, 4] / (2 ** bit_depth - 1)
    assert raw.min() > 1.2


def test_coarse_2d_warp_is_level_1_and_alpha_only_is_color_level_1(tmp_path):
    buffers = _buffers_2d(grid=(12, 16), with_beta=False, gamma=1.0)
    package = read_mpcdi(write_mpcdi(tmp_path / "coarse.mpcdi", "2d", buffers, bit_depth=8, date=DATE))
    root = _root(package)
    assert (root.get("geometry"), root.get("color"), root.get("level")) == ("1", "1", "1")  # 32x32 at most
    for fileset in root.find("files"):
        assert [c.tag for c in fileset] == ["geometryWarpFile", "alphaMap"]
        assert fileset.find("alphaMap").findtext("bitDepth") == "8"
        assert float(fileset.find("alphaMap").findtext("gammaEmbedded")) == 1.0
    assert _same_bits(package.warp("left"), _stored_2d(_warp_2d(0.0, (12, 16))))
    assert png_header(package.members[package.regions["left"].alpha.path]) == (W, H, 8, 0)
    assert np.array_equal(package.stored_map("left", "alpha"), np.rint(255 * _alpha("left")))
    assert sorted(package.members) == ["left_alpha.png", "left_warp.pfm", "mpcdi.xml", "right_alpha.png",
                                       "right_warp.pfm"]


def test_unknown_2d_texels_get_error_one_and_regions_can_tile_a_buffer(tmp_path):
    """3.6.2: unknown (u, v) is NaN with error 1.0. Two regions side by side in one buffer (2.1)."""
    warp = _warp_2d(0.0, (12, 16))
    warp[3, 4] = np.nan
    halves = [MpcdiRegion(f"half-{i}", (32, 48), 0.5 * i, 0.0, 0.5, 1.0, warp, np.ones((48, 32))) for i in range(2)]
    package = read_mpcdi(write_mpcdi(tmp_path / "tiled.mpcdi", "2d", [MpcdiBuffer("ig", (64, 48), halves)], date=DATE))
    stored = package.warp("half-0")
    assert np.isnan(stored[3, 4, :2]).all() and stored[3, 4, 2] == 1.0
    assert np.isnan(stored[0, 0, 2])
    assert [(r.x, r.xsize, r.resolution) for r in package.buffers[0].regions] == [(0.0, 0.5, (32, 48)),
                                                                                 (0.5, 0.5, (32, 48))]


def test_ids_that_are_no_file_names_still_give_root_level_members(tmp_path):
    buffers = [MpcdiBuffer("b/1", (W, H), [_region_2d("left", id="proj 1/α")]),
               MpcdiBuffer("b 2", (W, H), [_region_2d("right", id="proj_1")])]
    package = read_mpcdi(write_mpcdi(tmp_path / "names.mpcdi", "2d", buffers, date=DATE))
    assert set(package.regions) == {"proj 1/α", "proj_1"}
    assert all("/" not in name for name in package.members)
    assert len({name.lower() for name in package.members}) == len(package.members)


# ---- the sl profile: shader lamps ----

def test_shader_lamp_package_has_3d_points_frustum_and_frame(tmp_path):
    path = write_mpcdi(tmp_path / "lamps.mpcdi", "sl", _buffers_sl(), origin_of_3d_data="floorCenter", date=DATE)
    package = read_mpcdi(path)
    root = _root(package)
    # table 3-2: with per-pixel lens distortion maps, shader lamps are geometry level 2
    assert [root.get(a) for a in ("profile", "geometry", "color", "version")] == ["sl", "2", "2", "2.0"]
    for buffer_element in root.find("display"):
        assert len(buffer_element.findall("region")) == 1  # one region per buffer (3.5.2)
    for name in STARTS:
        region = package.regions[name]
        element = root.find(f"display/buffer/region[@id='{name}']")
        assert [c.tag for c in element] == ["frustum", "coordinateFrame", "color"]
        assert [c.tag for c in element.find("frustum")] == ["yaw", "pitch", "roll", "rightAngle", "leftAngle",
                                                            "upAngle", "downAngle"]
        assert [c.tag for c in element.find("coordinateFrame")] == [p + a for p in ("pos", "yaw", "pitch", "roll")
                                                                   for a in "xyz"]
        expected = _region_sl(name)
        assert region.frustum == expected.frustum  # doubles written exactly
        assert region.frustum.left_angle < region.frustum.right_angle
        assert region.frustum.down_angle < region.frustum.up_angle
        assert region.coordinate_frame == FRAMES[name]
        assert region.warp.geometric_unit == "m" and region.warp.origin_of_3d_data == "floorCenter"
        fileset = root.find(f"files/fileset[@region='{name}']")
        assert [c.tag for c in fileset] == ["geometryWarpFile", "alphaMap", "betaMap", "distortionMap"]
        assert fileset.find("distortionMap").findtext("path") in package.members
        assert [c.tag for c in fileset.find("distortionMap")] == ["path"]  # only a path (3.5.2)
        # 3D positions per texel: a three-component PFM that round-trips bit for bit, NaN where unknown
        points = package.warp(name)
        assert points.shape == (12, 16, 3) and np.isnan(points[0, 0]).all()
        assert _same_bits(points, _wall_points(STARTS[name]))
        assert _same_bits(package.distortion(name), _stored_2d(expected.distortion))


def test_shader_lamps_without_distortion_maps_are_level_1(tmp_path):
    package = read_mpcdi(write_mpcdi(tmp_path / "lamps.mpcdi", "sl", _buffers_sl(distortion=False), date=DATE))
    root = _root(package)
    assert root.get("geometry") == "1"
    assert all(fileset.find("distortionMap") is None for fileset in root.find("files"))


def test_frustum_from_a_pinhole():
    frustum = MpcdiFrustum.from_pinhole(100.0, 100.0, 50.0, 40.0, (100, 80))
    assert frustum.right_angle == pytest.approx(26.565051177) and frustum.left_angle == pytest.approx(-26.565051177)
    assert frustum.up_angle == pytest.approx(21.801409486) and frustum.down_angle == pytest.approx(-21.801409486)


# ---- bad input: one clear line, nothing written ----

def _two_regions_in_one_sl_buffer():
    return [MpcdiBuffer("both", (2 * W, H), [_region_sl("left", xsize=0.5), _region_sl("right", x=0.5, xsize=0.5)])]


BAD_INPUT = {
    "unknown profile": (dict(profile="3d"), r"unknown MPCDI profile '3d'"),
    "not a profile": (dict(profile="flat"), r"unknown MPCDI profile 'flat'"),
    "not a .mpcdi name": (dict(name="wall.zip"), r"ends in \.mpcdi"),
    "warp of one channel": (dict(buffers=_buffers_2d(warp=np.zeros((H, W), np.float32))), r"region 'left' warp"),
    "warp of four channels": (dict(buffers=_buffers_2d(warp=np.zeros((H, W, 4), np.float32))), r"\(h, w, 2 or 3\)"),
    "warp of 1x1": (dict(buffers=_buffers_2d(warp=np.zeros((1, 1, 2), np.float32))), r"at least 2x2"),
    "warp finer than the pixels": (dict(buffers=_buffers_2d(warp=np.zeros((H, W + 1, 2), np.float32))), r"finer"),
    "warp outside [0, 1]": (dict(buffers=_buffers_2d(warp=_warp_2d(0.5))), r"normalised to \[0, 1\]"),
    "alpha of another size": (dict(buffers=_buffers_2d(alpha=np.ones((H, W - 1)))), r"alpha has shape \(48, 63\)"),
    "alpha above 1": (dict(buffers=_buffers_2d(alpha=np.full((H, W), 1.5))), r"alpha must lie in \[0, 1\]"),
    "beta below 0": (dict(buffers=_buffers_2d(beta=np.full((H, W), -0.1))), r"beta must lie in \[0, 1\]"),
    "region smaller than its share": (dict(buffers=[MpcdiBuffer("wide", (2 * W, H), [_region_2d("left")])]),
                                      r"is 64x48 pixels but covers 1x1 of buffer 'wide'"),
    "region past the buffer": (dict(buffers=[MpcdiBuffer("b", (2 * W, H), [_region_2d("left", x=0.6, xsize=0.5)])]),
                               r"reaches past buffer 'b'"),
    "size above 1": (dict(buffers=_buffers_2d(xsize=1.5)), r"xsize must be in \(0.0, 1.0\]"),
    "region ids used twice": (dict(buffers=[MpcdiBuffer(f"b{i}", (W, H), [_region_2d("left")]) for i in range(2)]),
                              r"region id 'left' is used twice"),
    "buffer ids used twice": (dict(buffers=[MpcdiBuffer("b", (W, H), [_region_2d(n)]) for n in STARTS]),
                              r"buffer id 'b' is used twice"),
    "no buffers": (dict(buffers=[]), r"non-empty list of MpcdiBuffer"),
    "2d with a frustum": (dict(buffers=_buffers_2d(frustum=MpcdiFrustum(0, 0, 0, 20, -20, 15, -15))),
                          r"profile '2d' has none"),
    "sl with two regions in a buffer": (dict(profile="sl", buffers=_two_regions_in_one_sl_buffer()),
                                        r"allows one per buffer"),
    "sl without frustum": (dict(profile="sl", buffers=_buffers_sl(frustum=None)), r"needs a frustum"),
    "sl with 2D warp": (dict(profile="sl", buffers=_buffers_sl(warp=_warp_2d(0.0))), r"must hold 3D points"),
    "sl frustum left >= right": (dict(profile="sl",
                                      buffers=_buffers_sl(frustum=MpcdiFrustum(0, 0, 0, -20, 20, 15, -15))),
                                 r"left angle 20 must be less than right angle -20"),
    "sl axes not orthonormal": (dict(profile="sl", buffers=_buffers_sl(coordinate_frame=MpcdiCoordinateFrame(
        (0, 0, 0), (0, 1, 0), (1, 0.1, 0), (0, 0, -1)))), r"orthonormal"),
    "sl origin at the eye": (dict(profile="sl", buffers=_buffers_sl(), origin_of_3d_data="idealEyePoint"),
                             r"cannot have its 3D data's origin at idealEyePoint"),
    "bad alpha gamma": (dict(buffers=_buffers_2d(gamma=0.0)), r"alpha gamma must be above 0"),
    "bad bit depth": (dict(bit_depth=32), r"bit depth must be 8 or 16"),
    "bit depth not an integer": (dict(bit_depth=16.0), r"bit depth must be 8 or 16"),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_one_clear_line_and_writes_nothing(tmp_path, case):
    changes, pattern = BAD_INPUT[case]
    arguments = dict(profile="2d", buffers=_buffers_2d(), name="wall.mpcdi") | changes
    target = tmp_path / arguments.pop("name")
    with pytest.raises(ValueError, match=pattern) as exc:
        write_mpcdi(target, arguments["profile"], arguments["buffers"], date=DATE,
                    **{k: v for k, v in arguments.items() if k not in ("profile", "buffers")})
    _one_line(exc)
    assert list(tmp_path.iterdir()) == []


def test_a_path_that_cannot_be_written_is_one_oserror_line(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    with pytest.raises(OSError) as exc:
        write_mpcdi(blocker / "wall.mpcdi", "2d", _buffers_2d(), date=DATE)
    assert "cannot write the MPCDI package" in _one_line(exc) and "a-file" in str(exc.value)
    (tmp_path / "taken.mpcdi").mkdir()
    with pytest.raises(OSError) as exc:
        write_mpcdi(tmp_path / "taken.mpcdi", "2d", _buffers_2d(), date=DATE)
    assert "taken.mpcdi" in _one_line(exc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "taken.mpcdi"]  # no temporary left


def test_a_failed_write_keeps_the_previous_package(tmp_path, monkeypatch):
    path = write_mpcdi(tmp_path / "wall.mpcdi", "2d", _buffers_2d(), date=DATE)
    before = path.read_bytes()

    def full_disk(handle, data):
        handle.write(data[: len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic, "write_all", full_disk)
    with pytest.raises(OSError) as exc:
        write_mpcdi(path, "2d", _buffers_2d(gamma=1.0), date=DATE + dt.timedelta(days=1))
    assert "No space left on device" in _one_line(exc) and exc.value.errno == errno.ENOSPC
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["wall.mpcdi"]
    assert read_mpcdi(path).regions["left"].alpha.gamma_embedded == GAMMA


# ---- the reader is strict too ----

def _rezip(source, target, replace):
    with zipfile.ZipFile(source) as archive, zipfile.ZipFile(target, "w") as out:
        for info in archive.infolist():
            out.writestr(info.filename, replace.get(info.filename, archive.read(info)))
        for name, data in replace.items():
            if name not in archive.namelist():
                out.writestr(name, data)


def test_reader_refuses_what_the_spec_does_not_allow(tmp_path):
    good = write_mpcdi(tmp_path / "good.mpcdi", "2d", _buffers_2d(), date=DATE)
    xml = read_mpcdi(good).descriptor
    cases = {
        "entities": xml.replace(b"?>\n", b'?>\n<!DOCTYPE MPCDI [<!ENTITY x "y">]>\n', 1),
        "version": xml.replace(b'version="2.0"', b'version="1.0"'),
        "missing path": xml.replace(b"<path>left_alpha.png</path>", b"<path>gone.png</path>"),
        "declaration": xml.replace(b'encoding="utf-8"', b'encoding="latin-1"'),
        "conflicting spellings": xml.replace(b'xsize="1.0"', b'xsize="0.5"', 1),
    }
    for case, descriptor in cases.items():
        target = tmp_path / f"{case}.mpcdi"
        _rezip(good, target, {"mpcdi.xml": descriptor})
        with pytest.raises(ValueError) as exc:
            read_mpcdi(target)
        _one_line(exc)
    folder = tmp_path / "folder.mpcdi"
    _rezip(good, folder, {"maps/extra.png": b""})
    with pytest.raises(ValueError, match="no folders"):
        read_mpcdi(folder)
    not_zip = tmp_path / "plain.mpcdi"
    not_zip.write_bytes(io.BytesIO(b"plain").getvalue())
    with pytest.raises(ValueError, match="not a ZIP"):
        read_mpcdi(not_zip)


def test_encode_alpha_embeds_the_gamma():
    alpha = np.array([[0.0, 0.25], [0.5, 1.0]])
    stored = encode_alpha(alpha, 2.2, 16)
    assert stored.dtype == np.uint16
    assert np.allclose((stored / 65535.0) ** 2.2, alpha, atol=1e-4)
    assert encode_alpha(alpha, 1.0, 8).tolist() == [[0, 64], [128, 255]]
