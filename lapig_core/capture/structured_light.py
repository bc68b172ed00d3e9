# SPDX-License-Identifier: GPL-3.0-or-later
"""Gray-code structured light: patterns, decoding and the projector -> camera map.

Conventions (shared with the exact ray-cast check elsewhere): image coordinates follow OpenCV,
pixel (col i, row j) has its centre at (x=i, y=j) and arrays are indexed [row, col]. A camera
point anywhere inside projector pixel (px, py) decodes to (px, py), whose continuous position is
that pixel's centre (px, py).

Pattern order (``graycode_patterns``), as produced by OpenCV's ``GrayCodePattern.generate``:
for each column bit, most significant first, the pattern (white where that bit of the Gray code
of the column is 1) then its complement; then the same for the row bits; we append a plain white
and a plain black frame. With n_c = ceil(log2 Wp) and n_r = ceil(log2 Hp) bits that is
2 * (n_c + n_r) + 2 images (42 for 800x600, 40 for 1024x768).

Plain Python + numpy + OpenCV; never imports bpy.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

# Default thresholds, in 8-bit units (scaled by 1/255 for float captures in [0, 1]).
BLACK_THRESHOLD = 20.0  # white - black must exceed this: the pixel is lit by the projector
WHITE_THRESHOLD = 5.0  # |pattern - complement| must reach this for every bit: bit is readable


def _bits(n: int) -> int:
    return (int(n) - 1).bit_length()  # ceil(log2 n), as OpenCV counts pattern bits


def _check_proj_size(proj_width, proj_height):
    if int(proj_width) != proj_width or int(proj_height) != proj_height:
        raise ValueError(f"projector size must be integers, got {proj_width}x{proj_height}")
    if proj_width < 2 or proj_height < 2:
        raise ValueError(f"projector size must be at least 2x2, got {proj_width}x{proj_height}")
    return int(proj_width), int(proj_height)


def pattern_count(proj_width: int, proj_height: int) -> int:
    """Number of images ``graycode_patterns`` returns (Gray-code pairs + white + black)."""
    w, h = _check_proj_size(proj_width, proj_height)
    return 2 * (_bits(w) + _bits(h)) + 2


def graycode_patterns(proj_width: int, proj_height: int) -> list[np.ndarray]:
    """OpenCV's Gray-code pattern set followed by plain white and plain black, uint8 (Hp, Wp).

    Order: [col bit MSB, its complement, ..., col bit LSB, complement, row bit MSB, complement,
    ..., row bit LSB, complement, white, black] (see the module docstring).
    """
    w, h = _check_proj_size(proj_width, proj_height)
    ok, pats = cv2.structured_light.GrayCodePattern.create(w, h).generate()
    if not ok:
        raise RuntimeError("OpenCV failed to generate the Gray-code patterns")
    out = [np.ascontiguousarray(p, dtype=np.uint8) for p in pats]
    out.append(np.full((h, w), 255, np.uint8))
    out.append(np.zeros((h, w), np.uint8))
    return out


@dataclass
class DecodeResult:
    """Per camera pixel: the projector pixel it sees (-1 where not decoded) and a validity mask."""

    proj_x: np.ndarray  # int32 (H, W)
    proj_y: np.ndarray  # int32 (H, W)
    valid: np.ndarray  # bool (H, W)

    @property
    def shape(self) -> tuple[int, int]:
        return self.valid.shape


_LUMA = np.array([0.299, 0.587, 0.114], np.float32)  # Rec.601 weights, channels taken as RGB


def _gray_8bit(img: np.ndarray, index: int) -> np.ndarray:
    """One capture -> float32 gray in 8-bit units (uint8 as is, floats in [0, 1] times 255)."""
    if img.dtype == np.uint8:
        scale = 1.0
    elif np.issubdtype(img.dtype, np.floating):
        scale = 255.0
    else:
        raise ValueError(f"capture {index}: dtype {img.dtype} not supported (use uint8 or float in [0, 1])")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 3 and img.shape[2] in (3, 4):
        g = img[:, :, :3].astype(np.float32) @ (_LUMA * np.float32(scale))  # alpha dropped
    elif img.ndim == 2:
        g = img.astype(np.float32) * np.float32(scale)
    else:
        raise ValueError(f"capture {index}: shape {img.shape} is neither HxW nor HxWx(1|3|4)")
    return g


def _checked_captures(captures, expected: int) -> list[np.ndarray]:
    """Validate count and shapes; gray conversion happens later, one image at a time (memory)."""
    if isinstance(captures, np.ndarray) and captures.ndim not in (3, 4):
        raise ValueError(f"captures array must be N,H,W or N,H,W,C, got shape {captures.shape}")
    caps = [np.asarray(c) for c in captures]
    if len(caps) != expected:
        raise ValueError(f"expected {expected} captures (Gray-code pairs + white + black), got {len(caps)}")
    for k, c in enumerate(caps):
        if c.shape != caps[0].shape:
            raise ValueError(f"capture {k} has shape {c.shape}, capture 0 has {caps[0].shape}")
    _gray_8bit(caps[0], 0)  # fail early on a bad dtype or channel count
    return caps


def decode_graycode(
    captures: Sequence[np.ndarray] | np.ndarray,
    proj_width: int,
    proj_height: int,
    black_threshold: float = BLACK_THRESHOLD,
    white_threshold: float = WHITE_THRESHOLD,
) -> DecodeResult:
    """Decode camera captures of ``graycode_patterns`` into projector pixel coordinates.

    ``captures``: sequence of HxW or HxWx3 (RGB; x4 drops alpha) images, or one N,H,W[,C] array,
    uint8 or float in [0, 1], in pattern order (last two: white, black). Colour is converted to
    Rec.601 luma. Thresholds are in 8-bit units whatever the dtype (default black 20, white 5).

    A camera pixel is valid where white - black > black_threshold, every bit has
    |pattern - complement| >= white_threshold, and the decoded (x, y) lies inside the projector.
    Bits are read as pattern > complement, exactly like ``GrayCodePattern.getProjPixel``.
    """
    return decode_graycode_partial(captures, proj_width, proj_height, black_threshold, white_threshold).decoded()


def finest_bit_indices(proj_width: int, proj_height: int) -> list[int]:
    """Indices into graycode_patterns of the finest column and row bits and their complements: the
    stripes a blurred, noisy or moving camera decodes least reliably, captured again to check the decode."""
    w, h = _check_proj_size(proj_width, proj_height)
    nc, nr = _bits(w), _bits(h)
    return [2 * nc - 2, 2 * nc - 1, 2 * (nc + nr) - 2, 2 * (nc + nr) - 1]


@dataclass
class PartialCode:
    """What the Gray code says where it cannot say everything: per camera pixel and axis, which bits read
    (``*_read``, a bit mask, most significant bit first as the patterns are) and their values (``*_gray``),
    and whether the projector lights the pixel at all. Where a camera pixel spans more projector pixels
    than the finest stripes are wide (a surface at grazing incidence) those bits read grey; where it
    straddles a stripe edge, that one bit does. Gray code changes one bit per edge, so every other bit
    still reads, and ``positions`` gives the projector pixels they allow."""

    x_read: np.ndarray  # int32 (H, W)
    x_gray: np.ndarray
    y_read: np.ndarray
    y_gray: np.ndarray
    lit: np.ndarray  # bool (H, W): white - black above the black threshold
    size: tuple[int, int]  # the projector's (width, height)

    def decoded(self) -> DecodeResult:
        """The strict decode: valid where the pixel is lit, every bit of both axes reads and the position lies
        inside the projector (``decode_graycode``)."""
        (w, h), (nc, nr) = self.size, (_bits(self.size[0]), _bits(self.size[1]))
        px, py = _gray_to_binary(self.x_gray, nc), _gray_to_binary(self.y_gray, nr)
        valid = self.lit & (self.x_read == (1 << nc) - 1) & (self.y_read == (1 << nr) - 1) & (px < w) & (py < h)
        return DecodeResult(np.where(valid, px, -1).astype(np.int32), np.where(valid, py, -1).astype(np.int32), valid)

    def positions(self, axis: str, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(N, size) bool: the projector columns (axis "x") or rows ("y") whose Gray code agrees with every
        bit read at the N camera pixels (rows, cols)."""
        n = self.size[0] if axis == "x" else self.size[1]
        read = (self.x_read if axis == "x" else self.y_read)[rows, cols].astype(np.int64)
        gray = (self.x_gray if axis == "x" else self.y_gray)[rows, cols].astype(np.int64)
        codes = np.arange(n, dtype=np.int64)
        codes ^= codes >> 1
        return ((codes[None, :] ^ gray[:, None]) & read[:, None]) == 0


def _gray_to_binary(gray: np.ndarray, nbits: int) -> np.ndarray:
    """Gray code -> binary, bit by bit from the most significant: b_k = b_{k+1} xor g_k."""
    binary = gray.astype(np.int32).copy()
    shift = 1
    while shift < nbits:
        binary ^= binary >> shift
        shift <<= 1
    return binary


def decode_graycode_partial(
    captures: Sequence[np.ndarray] | np.ndarray,
    proj_width: int,
    proj_height: int,
    black_threshold: float = BLACK_THRESHOLD,
    white_threshold: float = WHITE_THRESHOLD,
) -> PartialCode:
    """Every bit that reads (|pattern - complement| >= ``white_threshold``), per camera pixel and axis, with
    the thresholds of ``decode_graycode``: where every bit reads, ``positions`` is the one pixel it decodes."""
    w, h = _check_proj_size(proj_width, proj_height)
    nc, nr = _bits(w), _bits(h)
    caps = _checked_captures(captures, 2 * (nc + nr) + 2)
    n = len(caps)
    lit = (_gray_8bit(caps[-2], n - 2) - _gray_8bit(caps[-1], n - 1)) > black_threshold

    def read(first: int, nbits: int):
        mask = np.zeros(lit.shape, np.int32)
        value = np.zeros(lit.shape, np.int32)
        for k in range(nbits):
            i = first + 2 * k
            diff = _gray_8bit(caps[i], i) - _gray_8bit(caps[i + 1], i + 1)
            bit = np.int32(1 << (nbits - 1 - k))
            mask |= np.where(np.abs(diff) >= white_threshold, bit, 0).astype(np.int32)
            value |= np.where(diff > 0, bit, 0).astype(np.int32)
        return mask, value & mask

    x_read, x_gray = read(0, nc)
    y_read, y_gray = read(2 * nc, nr)
    return PartialCode(x_read, x_gray, y_read, y_gray, lit, (w, h))


def decode_agreement(first, second, indices, valid: np.ndarray) -> float:
    """The share of decoded camera pixels whose bits read the same in two captures of the same patterns
    (``first``: every Gray-code capture; ``second``: the captures of ``indices`` again, in pairs of a
    pattern and its complement)."""
    same = np.ones(valid.shape, bool)
    for k in range(0, len(indices), 2):
        i = indices[k]
        bit_a = _gray_8bit(first[i], i) > _gray_8bit(first[i + 1], i + 1)
        bit_b = _gray_8bit(second[k], i) > _gray_8bit(second[k + 1], i + 1)
        same &= bit_a == bit_b
    return float(same[valid].mean()) if valid.any() else 0.0


# --------------------------------------------------------------------------
# Projector -> camera map
# --------------------------------------------------------------------------


def _neighbour_agreement(px, py, valid, tol: float) -> np.ndarray:
    """Number of 8-neighbours decoding within ``tol`` projector pixels (Chebyshev)."""
    H, W = valid.shape
    pad = lambda a, v: np.pad(a, 1, constant_values=v)  # noqa: E731
    qx, qy, qv = pad(px, -1), pad(py, -1), pad(valid, False)
    count = np.zeros((H, W), np.int32)
    for dj in (-1, 0, 1):
        for di in (-1, 0, 1):
            if di == 0 and dj == 0:
                continue
            sl = (slice(1 + dj, 1 + dj + H), slice(1 + di, 1 + di + W))
            ok = qv[sl] & (np.abs(qx[sl] - px) <= tol) & (np.abs(qy[sl] - py) <= tol)
            count += ok
    return count


def _sample_density(px, py, ok) -> float:
    """Camera samples per projector pixel: 1 / |mean det d(proj)/d(cam)| from forward differences."""
    px = px.astype(np.float64)
    py = py.astype(np.float64)
    m = ok[:-1, :-1] & ok[:-1, 1:] & ok[1:, :-1]
    dxu = (px[:-1, 1:] - px[:-1, :-1])[m]
    dyu = (py[:-1, 1:] - py[:-1, :-1])[m]
    dxv = (px[1:, :-1] - px[:-1, :-1])[m]
    dyv = (py[1:, :-1] - py[:-1, :-1])[m]
    smooth = np.maximum.reduce([np.abs(dxu), np.abs(dyu), np.abs(dxv), np.abs(dyv)]) <= 16  # no depth jumps
    if smooth.sum() < 16:
        return 1.0
    det = abs(float(np.mean(dxu[smooth] * dyv[smooth] - dyu[smooth] * dxv[smooth])))
    return float(np.clip(1.0 / max(det, 1e-6), 1.0 / 64, 64.0))


def projector_to_camera_map(
    decoded: DecodeResult,
    proj_width: int,
    proj_height: int,
    sigma: float | None = None,
    max_offset: float = 0.8,
    max_residual: float = 1.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Dense map from every native projector pixel centre to continuous camera coordinates.

    Each decoded camera pixel is a sample: camera centre (i, j) seen at projector pixel (px, py).
    Around every projector pixel p we fit camera = b + A (q - p) by Gaussian-weighted least squares
    over the samples q; b is the estimate. The weighted moments are accumulated on the projector
    grid and filtered with separable kernels g, x g, x^2 g, so everything is whole-image work.

    ``sigma`` (projector pixels): Gaussian width; None picks max(1.5, 1.5 x sample spacing) from
    the measured sample density (1.5 when the camera is finer than the projector, ~2.7 at 0.55
    camera px per projector px); larger is smoother but widens the invalid band at depth edges.

    A projector pixel is valid where its window has enough support, a sample lies within
    max(1.5, 1.2 x sample spacing) pixels, the samples' weighted centroid is within
    ``max_offset * sigma`` (no extrapolation past edges), the fit is well conditioned, and its
    RMS residual is below ``max_residual`` projector pixels (windows straddling a depth
    discontinuity mix two surfaces). Isolated mis-decoded camera pixels (no two of their 8
    neighbours agree) are dropped first.

    Returns (cam_xy float32 (Hp, Wp, 2) holding [x, y], -1 where invalid; valid bool (Hp, Wp)).
    """
    w, h = _check_proj_size(proj_width, proj_height)
    if not isinstance(decoded, DecodeResult):
        raise ValueError("decoded must be a DecodeResult from decode_graycode")
    px, py, ok = decoded.proj_x, decoded.proj_y, decoded.valid.copy()
    if not (px.shape == py.shape == ok.shape) or ok.ndim != 2:
        raise ValueError(f"DecodeResult arrays disagree in shape: {px.shape}, {py.shape}, {ok.shape}")
    ok &= (px >= 0) & (px < w) & (py >= 0) & (py < h)
    cam_xy = np.full((h, w, 2), -1.0, np.float32)
    valid = np.zeros((h, w), bool)
    if ok.sum() < 16:
        return cam_xy, valid

    rho = _sample_density(px, py, ok)  # camera samples per projector pixel
    step = 1.0 / np.sqrt(rho)  # projector pixels between neighbouring camera pixels
    # Drop isolated mis-decodes (bit errors jump far): need two neighbours that agree.
    ok &= _neighbour_agreement(px, py, ok, tol=2.0 + 2.0 * step) >= 2
    if ok.sum() < 16:
        return cam_xy, valid
    if sigma is None:
        sigma = float(np.clip(1.5 * step, 1.5, 8.0))  # >= ~14 samples in the window
    if not sigma > 0:
        raise ValueError(f"sigma must be positive, got {sigma}")

    jj, ii = np.nonzero(ok)
    cell = py[jj, ii].astype(np.int64) * w + px[jj, ii]
    # Camera coordinates relative to their mean keep the float64 moments well scaled.
    cu0, cv0 = float(ii.mean()), float(jj.mean())
    cu, cv = ii - cu0, jj - cv0
    n_cells = w * h

    def acc(weights=None):
        return np.bincount(cell, weights=weights, minlength=n_cells).reshape(h, w).astype(np.float64)

    n = acc()
    su, sv = acc(cu), acc(cv)
    sq = acc(cu * cu) + acc(cv * cv)  # only the total squared norm is needed for residuals

    r = int(np.ceil(3 * sigma))
    d = np.arange(-r, r + 1, dtype=np.float64)
    g = np.exp(-0.5 * (d / sigma) ** 2)
    g1, g2 = d * g, d * d * g

    def filt(img, kx, ky):  # correlation: sum_q k(q - p) img(q); zero outside the frame
        return cv2.sepFilter2D(img, cv2.CV_64F, kx, ky, borderType=cv2.BORDER_CONSTANT)

    base = np.dstack([n, su, sv])
    m0 = filt(base, g, g)  # [sum w, sum w cu, sum w cv]
    mx = filt(base, g1, g)  # [sum w dx, sum w dx cu, sum w dx cv]
    my = filt(base, g, g1)
    m20 = filt(n, g2, g)
    m11 = filt(n, g1, g1)
    m02 = filt(n, g, g2)
    mcc = filt(sq, g, g)

    s0, s1, s2 = m0[..., 0], mx[..., 0], my[..., 0]
    has = s0 > 1e-9
    s0s = np.where(has, s0, 1.0)
    # Normal equations [[s0 s1 s2][s1 m20 m11][s2 m11 m02]] beta = rhs; symmetric adjugate inverse.
    c00 = m20 * m02 - m11 * m11
    c01 = s2 * m11 - s1 * m02
    c02 = s1 * m11 - m20 * s2
    c11 = s0 * m02 - s2 * s2
    c12 = s1 * s2 - s0 * m11
    c22 = s0 * m20 - s1 * s1
    det = s0 * c00 + s1 * c01 + s2 * c02
    # Conditioning: determinant of the weighted covariance of sample offsets vs a full window.
    cov_det = np.where(has, det / s0s**3, 0.0)
    good = has & (cov_det > 0.04 * sigma**4)
    det = np.where(good, det, 1.0)

    sse = mcc.copy()
    est = []
    for ch in (1, 2):
        r0, r1, r2 = m0[..., ch], mx[..., ch], my[..., ch]
        b0 = (c00 * r0 + c01 * r1 + c02 * r2) / det
        b1 = (c01 * r0 + c11 * r1 + c12 * r2) / det
        b2 = (c02 * r0 + c12 * r1 + c22 * r2) / det
        sse -= b0 * r0 + b1 * r1 + b2 * r2
        est.append(b0)
    rms = np.sqrt(np.maximum(sse, 0.0) / s0s)  # camera pixels

    full = 2 * np.pi * sigma**2 * rho  # expected support of a fully covered window
    offset = np.hypot(s1, s2) / s0s
    # Distance to the nearest sample: stops wide windows reaching into holes round corners.
    gap = cv2.distanceTransform((n == 0).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    valid = (
        good
        & (gap <= max(1.5, 1.2 * step))
        & (s0 >= 0.25 * full)
        & (offset <= max_offset * sigma)
        & (rms <= max_residual * np.sqrt(rho))  # sqrt(rho): camera px per projector px
    )
    cam_xy[..., 0] = np.where(valid, est[0] + cu0, -1.0)
    cam_xy[..., 1] = np.where(valid, est[1] + cv0, -1.0)
    return _extend_frame_border(cam_xy, valid)


def _extend_frame_border(cam_xy: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fill the outermost rows/columns of the frame where the two pixels inside are valid.

    At the frame edge the samples lie on one side only, so the centroid test above rejects some
    edge pixels; the map is locally affine, so one step of linear extrapolation is accurate there.
    """
    cam_xy, valid = cam_xy.copy(), valid.copy()
    edges = [(np.s_[0, :], np.s_[1, :], np.s_[2, :]), (np.s_[-1, :], np.s_[-2, :], np.s_[-3, :]),
             (np.s_[:, 0], np.s_[:, 1], np.s_[:, 2]), (np.s_[:, -1], np.s_[:, -2], np.s_[:, -3])]
    for edge, inner, inner2 in edges:
        fill = ~valid[edge] & valid[inner] & valid[inner2]
        cam_xy[edge][fill] = 2 * cam_xy[inner][fill] - cam_xy[inner2][fill]
        valid[edge] |= fill
    return cam_xy, valid
