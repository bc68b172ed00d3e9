"""The object's geometry as the projector sees it, for the looks of the world (issue 50, item 3): plain arrays, no
bpy. Blender casts the projector's rays (lapig_addon/blender/look_geometry.py) and hands over where each pixel
lands and the surface's normal there; on a real rig without a 3D model the captured surface stands in for it.

    geometry = from_hits(points, normals, up, fx, fy, cx, cy)        # (H, W, 3) each, projector coordinates
    geometry = from_capture(surface_rgb)                              # no model: the captured surface alone

Projector coordinates are OpenCV's: x right, y down, z along the projector's axis (the depth). What a look reads:
    valid       (H, W) the pixel lands on the object
    depth       (H, W) metres along the axis
    up          (H, W) the normal's share of the world's up: 1 a top, 0 a wall, -1 an underside (None: not known)
    downhill    (H, W, 2) the image direction water runs along the surface (unit, x and y in pixels)
    cavity      (H, W) 0..1: how far the pixel lies in a crevice (farther than its surroundings)
    curvature   (H, W) the normal's spread per pixel: > 0 convex (edges, ridges), < 0 concave (creases)
    surface_u, surface_v  (H, W) metres across the surface, so bricks keep their size in metres at any distance:
                the object's UV map where it has one (scaled to metres; wood grain then runs along its u, as a
                texture would), else box mapping in a frame upright to gravity
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CAVITY_SIGMA_PX = 4.0     # the crevice is measured against the surroundings within about this many pixels
CAPTURE_NOTE = ("no 3D model of the object: the look follows the captured surface (its dark places as crevices, "
                "the image's up as up)")


@dataclass
class LookGeometry:
    valid: np.ndarray
    depth: np.ndarray
    up: np.ndarray | None
    downhill: np.ndarray
    cavity: np.ndarray
    curvature: np.ndarray
    surface_u: np.ndarray
    surface_v: np.ndarray
    metres_across: float   # the frame's width in metres at the object's median depth (1.0 for a capture)
    source: str            # "scene" (the 3D model) or "capture" (the captured surface alone)
    note: str = ""
    mapping: str = "box"   # how surface_u, surface_v were made: "uv" (the object's UV map), "box", "image"

    @property
    def shape(self) -> tuple[int, int]:
        return self.valid.shape

    def to_dict(self) -> dict:
        """What result.json says of it."""
        v = self.valid
        return {"source": self.source, "note": self.note, "size": [int(self.shape[1]), int(self.shape[0])],
                "mapping": self.mapping,
                "on_object": round(float(v.mean()), 3),
                "depth_m": [round(float(np.nanmin(self.depth[v])), 3), round(float(np.nanmax(self.depth[v])), 3)]
                if v.any() and self.source == "scene" else None,
                "tops_share": round(float((self.up[v] > 0.7).mean()), 3) if self.up is not None and v.any() else None,
                "crevice_share": round(float((self.cavity[v] > 0.5).mean()), 3) if v.any() else 0.0}


def _blur(a: np.ndarray, sigma: float, weight: np.ndarray | None = None) -> np.ndarray:
    """Gaussian blur, normalised by `weight` (pixels off the object do not count)."""
    import cv2

    weight = np.ones_like(a) if weight is None else weight.astype(np.float32)
    num = cv2.GaussianBlur((a * weight).astype(np.float32), (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    den = cv2.GaussianBlur(weight, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    return num / np.maximum(den, 1e-6)


def _local_plane(a: np.ndarray, sigma: float, weight: np.ndarray) -> np.ndarray:
    """Each pixel's value on the plane fitted to its surroundings (Gaussian weights, `weight` where a pixel counts):
    exact for any affine field, at the frame's border and beside holes too."""
    h, w = a.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    xs, ys = (xs - w / 2) / sigma, (ys - h / 2) / sigma
    wt = weight.astype(np.float32)
    m = {k: _blur_raw(v * wt, sigma) for k, v in (("1", np.ones_like(a)), ("x", xs), ("y", ys), ("xx", xs * xs),
                                                   ("xy", xs * ys), ("yy", ys * ys), ("a", a), ("ax", a * xs),
                                                   ("ay", a * ys))}
    # the 3x3 normal equations of a + b x + c y around each pixel, solved there (xs, ys: the pixel's own at the end)
    mat = np.stack([np.stack([m["1"], m["x"], m["y"]], -1), np.stack([m["x"], m["xx"], m["xy"]], -1),
                    np.stack([m["y"], m["xy"], m["yy"]], -1)], -2)
    rhs = np.stack([m["a"], m["ax"], m["ay"]], -1)
    mat = mat + np.eye(3, dtype=np.float32) * 1e-6 * np.maximum(m["1"], 1e-6)[..., None, None]
    coef = np.linalg.solve(mat.astype(np.float64), rhs[..., None].astype(np.float64))[..., 0]
    return (coef[..., 0] + coef[..., 1] * xs + coef[..., 2] * ys).astype(np.float32)


def _blur_raw(a: np.ndarray, sigma: float) -> np.ndarray:
    import cv2

    return cv2.GaussianBlur(a.astype(np.float32), (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)


def _occlusions(q: np.ndarray, valid: np.ndarray, radius: int) -> np.ndarray:
    """Pixels within `radius` of a depth jump (one object in front of another; a crease is no jump): a step of
    inverse depth four times the steps on either side of it."""
    import cv2

    jump = np.zeros(q.shape, bool)
    for axis in (0, 1):
        d = np.abs(np.diff(q, axis=axis))
        before = np.concatenate([np.take(d, [0], axis), np.take(d, range(d.shape[axis] - 1), axis)], axis)
        after = np.concatenate([np.take(d, range(1, d.shape[axis]), axis), np.take(d, [-1], axis)], axis)
        j = d > 4 * np.maximum(before, after) + 1e-3 * np.abs(np.take(q, range(d.shape[axis]), axis))
        pad = [(0, 1) if a == axis else (0, 0) for a in (0, 1)]
        jump |= np.pad(j, pad)
    jump &= valid
    size = 2 * radius + 1
    return cv2.dilate(jump.astype(np.uint8), np.ones((size, size), np.uint8)) > 0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def _fill(a: np.ndarray, valid: np.ndarray, fill) -> np.ndarray:
    out = np.array(a, np.float32, copy=True)
    out[~valid] = fill
    return out


def upright_frame(up: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(right, up, ahead): the projector's x turned level, the world's up, and level ahead of the projector."""
    up = _unit(np.asarray(up, np.float64))
    right = np.array([1.0, 0.0, 0.0]) - up[0] * up
    if np.linalg.norm(right) < 1e-6:  # the projector looks straight up or down
        right = np.array([0.0, 1.0, 0.0]) - up[1] * up
    right = _unit(right)
    return right, up, np.cross(right, up)


def uv_in_metres(uv, points, valid) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(u, v, where) the UV map in metres, v downwards: one factor for the whole frame, the median of metres per UV
    unit between neighbouring pixels (a seam between islands is an outlier the median leaves out); None where under
    half of the object has UVs, or they do not change across it (a map collapsed to a point)."""
    if uv is None:
        return None
    uv = np.asarray(uv, np.float64)
    has = valid & np.isfinite(uv).all(-1)
    if has.sum() < max(16, 0.5 * valid.sum()):
        return None
    ratios = []
    for axis in (0, 1):
        both = np.take(has, range(1, has.shape[axis]), axis) & np.take(has, range(has.shape[axis] - 1), axis)
        duv = np.linalg.norm(np.diff(uv, axis=axis), axis=-1)
        dm = np.linalg.norm(np.diff(points, axis=axis), axis=-1)
        ok = both & (duv > 1e-9) & np.isfinite(dm)
        ratios.append((dm[ok] / duv[ok]))
    ratios = np.concatenate(ratios)
    if len(ratios) < 0.25 * has.sum():  # most neighbours share one UV: no map to follow
        return None
    per_unit = float(np.median(ratios))
    if not np.isfinite(per_unit) or per_unit <= 0:
        return None
    u = np.where(has, uv[..., 0] * per_unit, 0.0)
    v = np.where(has, -uv[..., 1] * per_unit, 0.0)  # UV's v runs up the texture; the looks' v runs down
    return u.astype(np.float32), v.astype(np.float32), has


def from_hits(points, normals, up, fx: float, fy: float, cx: float, cy: float, note: str = "",
              uv=None) -> LookGeometry:
    """The geometry from where each projector pixel lands (points, NaN where it lands on nothing) and the surface's
    normal there (turned towards the projector), both (H, W, 3) in projector coordinates; `up` the world's up in
    the same coordinates; fx, fy, cx, cy the projector's intrinsics at this size (pixels); uv (H, W, 2): where each
    lands in the object's UV map (NaN where it has none), or None."""
    points = np.asarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    valid = np.isfinite(points).all(-1) & np.isfinite(normals).all(-1) & (points[..., 2] > 0)
    if not valid.any():
        raise ValueError("the projector's rays land on nothing: no geometry for the look")
    h, w = valid.shape
    depth = points[..., 2]
    median = float(np.median(depth[valid]))
    p = np.where(valid[..., None], points, 0.0)
    n = _unit(np.where(valid[..., None], normals, np.array([0.0, 0.0, -1.0])))
    n = np.where((np.sum(n * p, -1) > 0)[..., None], -n, n)  # towards the projector
    right, up_v, ahead = upright_frame(up)
    up_share = (n @ up_v).astype(np.float32)
    # downhill: gravity along the surface, carried into the image by the projection's derivative
    g = -up_v
    t = g - (n @ g)[..., None] * n
    z = np.where(valid, depth, median)
    dpx = fx * (t[..., 0] * z - p[..., 0] * t[..., 2]) / (z * z)
    dpy = fy * (t[..., 1] * z - p[..., 1] * t[..., 2]) / (z * z)
    d = np.stack([dpx, dpy], -1)
    flat = np.linalg.norm(d, axis=-1) < 1e-9  # a level top: nothing runs; the image's down stands in
    d[flat] = (0.0, 1.0)
    downhill = _unit(d).astype(np.float32)
    # cavity: a pixel farther than its surroundings lies in a crevice. Inverse depth is affine in the image on any
    # plane, so a slanted flat wall has none; the recess is measured against the blur window's own size.
    # Occlusion edges are no crevices: the floor seen behind a box is not in its shadow.
    q = _fill(1.0 / np.where(valid, depth, median), valid, 0.0)
    around = _local_plane(q, CAVITY_SIGMA_PX, valid)
    recess = (around - q) / np.maximum(q, 1e-9)
    window = CAVITY_SIGMA_PX / max(fx, 1e-6)
    cavity = np.clip(recess / (0.15 * window), 0.0, 1.0).astype(np.float32)
    cavity[~valid | _occlusions(q, valid, int(2.5 * CAVITY_SIGMA_PX))] = 0.0
    # curvature: the normal's divergence in the image (per pixel), convex > 0
    gx = np.gradient(n[..., 0], axis=1)
    gy = np.gradient(n[..., 1], axis=0)
    curvature = (gx + gy).astype(np.float32)
    curvature[~valid] = 0.0
    # metric surface coordinates: box mapping in the upright frame (the axis the normal is most along drops out)
    a_r, a_u, a_a = np.abs(n @ right), np.abs(n @ up_v), np.abs(n @ ahead)
    pr, pu, pa = p @ right, -(p @ up_v), p @ ahead
    top = (a_u >= a_r) & (a_u >= a_a)
    side = ~top & (a_r > a_a)
    su = np.where(top, pr, np.where(side, pa, pr)).astype(np.float32)
    sv = np.where(top, pa, pu).astype(np.float32)
    mapping = "box"
    mapped = uv_in_metres(uv, points, valid)
    if mapped is not None:  # the object's own UV map: the look lies on it as a texture would
        mu, mv, has = mapped
        su, sv, mapping = np.where(has, mu, su), np.where(has, mv, sv), "uv"
    across = float(w) * median / fx
    return LookGeometry(valid, np.where(valid, depth, np.nan).astype(np.float32), up_share, downhill, cavity,
                        curvature, su, sv, across, "scene", note, mapping)


def from_capture(surface_rgb) -> LookGeometry:
    """No 3D model (a real rig): the captured surface under white light stands in. Its dark places, darker than
    their surroundings, are the crevices; up is the image's up and water runs down the image; the surface is
    flat, facing the projector, one frame-width across."""
    s = np.asarray(surface_rgb, np.float32)
    if s.ndim != 3 or s.shape[-1] != 3:
        raise ValueError(f"the captured surface must be (H, W, 3), got {s.shape}")
    h, w, _ = s.shape
    lum = s @ np.array([0.299, 0.587, 0.114], np.float32)
    around = _blur(lum, 2 * CAVITY_SIGMA_PX)
    cavity = np.clip((around - lum) / np.maximum(around, 0.05) / 0.3, 0.0, 1.0).astype(np.float32)
    long_side = float(max(h, w))
    v, u = np.meshgrid((np.arange(h) + 0.5) / long_side, (np.arange(w) + 0.5) / long_side, indexing="ij")
    downhill = np.zeros((h, w, 2), np.float32)
    downhill[..., 1] = 1.0
    return LookGeometry(np.ones((h, w), bool), np.ones((h, w), np.float32), None, downhill, cavity,
                        np.zeros((h, w), np.float32), (u * long_side / w).astype(np.float32),
                        (v * long_side / w).astype(np.float32), 1.0, "capture", CAPTURE_NOTE, "image")


def resized(geometry: LookGeometry, h: int, w: int) -> LookGeometry:
    """The same geometry at another size (the working frame's look rendered at the projector's native frame)."""
    import cv2

    if geometry.shape == (h, w):
        return geometry

    def r(a, nearest=False):
        a = np.asarray(a, np.float32)
        return cv2.resize(a, (w, h), interpolation=cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR)

    valid = r(geometry.valid.astype(np.float32), True) > 0.5
    downhill = np.stack([r(geometry.downhill[..., 0]), r(geometry.downhill[..., 1])], -1)
    return LookGeometry(valid, r(geometry.depth, True), None if geometry.up is None else r(geometry.up),
                        _unit(downhill).astype(np.float32), r(geometry.cavity),
                        r(geometry.curvature) * geometry.shape[1] / w, r(geometry.surface_u), r(geometry.surface_v),
                        geometry.metres_across, geometry.source, geometry.note, geometry.mapping)


def look_coordinates(geometry: LookGeometry, h: int, w: int):
    """u, v for the generators (torch, (h, w)): metres across the surface in shares of the frame's width at the
    object's median depth, so a look keeps its features per frame where the object stands at its median depth and
    their size in metres everywhere. Off the object: the plain image coordinates."""
    import torch

    g = resized(geometry, h, w)
    long_side = float(max(h, w))
    scale = (w / long_side) / g.metres_across  # a frame-width of metres -> a frame-width of the image's u
    v_img, u_img = np.meshgrid((np.arange(h) + 0.5) / long_side, (np.arange(w) + 0.5) / long_side, indexing="ij")
    u = np.where(g.valid, g.surface_u * scale, u_img)
    v = np.where(g.valid, g.surface_v * scale, v_img)
    return torch.as_tensor(u, dtype=torch.float32), torch.as_tensor(v, dtype=torch.float32)


GEOMETRY_FILE = "look_geometry.npz"  # beside result.json: the geometry the look was shaped by
_ARRAYS = ("valid", "depth", "up", "downhill", "cavity", "curvature", "surface_u", "surface_v")
_FORMAT = 1


def geometry_bytes(geometry: LookGeometry) -> bytes:
    """The geometry as the bytes of look_geometry.npz (numpy arrays and a few numbers, no pickled objects): a result
    keeps it, so a look made again from the result (a show's) is shaped as the still look was."""
    import io

    arrays = {name: np.asarray(getattr(geometry, name)) for name in _ARRAYS if getattr(geometry, name) is not None}
    arrays.update(format=np.array(_FORMAT), metres_across=np.array(geometry.metres_across),
                  source=np.array(geometry.source), note=np.array(geometry.note), mapping=np.array(geometry.mapping))
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def load_geometry(path) -> LookGeometry | None:
    """The geometry saved at `path` (geometry_bytes), or None where there is none or it is of another format or
    damaged: the look is then made without it, as before the file was kept."""
    import os
    import zipfile

    if not os.path.isfile(path):
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            if int(data["format"]) != _FORMAT:
                return None
            arrays = {name: (np.array(data[name]) if name in data.files else None) for name in _ARRAYS}
            if any(arrays[name] is None for name in _ARRAYS if name != "up"):
                return None
            return LookGeometry(**arrays, metres_across=float(data["metres_across"]), source=str(data["source"]),
                                note=str(data["note"]), mapping=str(data["mapping"]))
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None
