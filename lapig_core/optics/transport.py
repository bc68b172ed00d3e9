# SPDX-License-Identifier: GPL-3.0-or-later
"""How light travels in a capture: bounces, the projector's and the camera's lenses, vignetting.

Two modes. FAST is direct light through pinhole lenses (what the classical per-pixel model
assumes; quick to iterate). REALISTIC adds what a real room and real lenses do:
  * diffuse (and glossy) inter-reflection, rendered as a separate low-resolution pass whose
    irradiance the full-size albedo multiplies (see `indirect_from_light_passes`);
  * projector defocus: a thin lens focused at `projector_focus_m` with an aperture of
    `projector_lens_radius_mm`. Every surface point at depth z along the projector's axis gathers
    the projector image over a disk of radius R |1/f - 1/z| (in tan units; times the focal length
    in pixels, W * throw ratio, in projector pixels), which is exact for a thin lens away from
    depth edges and noise-free (`defocus_frame`);
  * camera defocus (Cycles depth of field) and natural vignetting (cos^4 falloff) of the camera.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

MODES = ("REALISTIC", "FAST")
BOUNCE_METHODS = ("passes", "difference")
INDIRECT_FITS = ("linear", "mean")


@dataclass(frozen=True)
class LightTransport:
    mode: str = "REALISTIC"
    bounces: int = 3  # diffuse / glossy / transmission bounces of the indirect pass
    indirect_samples: int = 16  # samples per pixel of the "difference" bounce pass ("passes": one per capture pixel)
    indirect_downscale: int = 4  # the indirect pass renders at 1/this of the capture size...
    indirect_min_width: int = 120  # ...but never narrower than this (a small capture's pass is not coarser)
    indirect_smooth_px: float = 3.0  # Gaussian sigma on the low-resolution bounce light (0: raw; references)
    # "linear": the normal-guided blur fits a plane to each pixel's neighbours (follows the rise of the
    # bounce light into a concave crease); "mean": their weighted mean (captures before 2026-12-02)
    indirect_fit: str = "linear"
    # "passes": one render's light-path passes, the irradiance times the full-size albedo (keeps the
    # texture the bounce light falls on); "difference": two renders, with and without bounces (references)
    bounce_method: str = "passes"
    projector_focus_m: float = 3.0
    projector_lens_radius_mm: float = 5.0  # 0: pinhole projector
    camera_dof: bool = False
    camera_focus_m: float = 3.0
    camera_f_number: float = 2.8
    camera_dof_samples: int = 16  # a lens blurs by sampling: the direct pass needs samples then
    subsurface_samples: int = 16  # subsurface scattering is sampled too: the direct pass of such a scene
    vignetting: float = 1.0  # 0: none, 1: natural cos^4 falloff

    def __post_init__(self):
        if self.mode not in MODES:
            raise ValueError(f"unknown light transport mode '{self.mode}': choose {' or '.join(MODES)}")
        if self.bounce_method not in BOUNCE_METHODS:
            raise ValueError(f"unknown bounce method '{self.bounce_method}': choose {' or '.join(BOUNCE_METHODS)}")
        if self.indirect_fit not in INDIRECT_FITS:
            raise ValueError(f"unknown bounce light fit '{self.indirect_fit}': choose {' or '.join(INDIRECT_FITS)}")

    @property
    def realistic(self) -> bool:
        return self.mode == "REALISTIC"

    @property
    def uses_bounces(self) -> bool:
        return self.realistic and self.bounces > 0

    @property
    def uses_projector_defocus(self) -> bool:
        return self.realistic and self.projector_lens_radius_mm > 0 and self.projector_focus_m > 0

    @property
    def uses_camera_dof(self) -> bool:
        return self.realistic and self.camera_dof

    @property
    def uses_vignetting(self) -> bool:
        return self.realistic and self.vignetting > 0

    def indirect_size(self, width: int, height: int) -> tuple[int, int]:
        """The bounce pass's render size for a capture of (width, height)."""
        scale = min(float(self.indirect_downscale), max(1.0, width / max(self.indirect_min_width, 1)))
        return max(1, round(width / scale)), max(1, round(height / scale))

    def label(self) -> str:
        """One line for the panel: which mode, and what it includes."""
        if not self.realistic:
            return "Fast (direct light, pinhole lenses)"
        parts = [f"{self.bounces} bounces" if self.uses_bounces else "no bounces"]
        if self.uses_projector_defocus:
            parts.append(f"projector focus {self.projector_focus_m:.2f} m")
        if self.uses_camera_dof:
            parts.append(f"camera f/{self.camera_f_number:g}")
        if self.uses_vignetting:
            parts.append("vignetting")
        return "Realistic (" + ", ".join(parts) + ")"

    def state(self) -> list:
        """What a capture depends on, rounded, for the rig's fingerprint."""
        if not self.realistic:
            return ["FAST"]
        return ["REALISTIC", self.bounces, self.indirect_samples, self.indirect_downscale, self.indirect_min_width,
                self.indirect_smooth_px,
                round(self.projector_focus_m, 4), round(self.projector_lens_radius_mm, 4),
                self.camera_dof, round(self.camera_focus_m, 4), round(self.camera_f_number, 3),
                self.camera_dof_samples, round(self.vignetting, 4), self.subsurface_samples,
                self.bounce_method, self.indirect_fit]

    def to_dict(self) -> dict:
        return {**asdict(self), "label": self.label()}


FAST = LightTransport(mode="FAST")


# -- projector defocus -----------------------------------------------------------------------
def blur_radius_px(depth_m, focus_m: float, lens_radius_m: float, focal_px: float) -> np.ndarray:
    """Thin-lens circle of confusion (radius, projector pixels) of points at `depth_m` along the axis."""
    depth = np.asarray(depth_m, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = lens_radius_m * np.abs(1.0 / focus_m - 1.0 / depth) * focal_px
    return np.where(np.isfinite(radius) & (depth > 0), radius, 0.0)


def disk_kernel(radius: float) -> np.ndarray:
    """A normalised disk of `radius` pixels, its edge pixels weighted by their covered area."""
    if radius < 0.5:
        k = np.zeros((1, 1), np.float32)
        k[0, 0] = 1
        return k
    half = int(np.ceil(radius + 0.5))
    sub = (np.arange(4) + 0.5) / 4 - 0.5  # 4x4 supersampling of each kernel pixel
    axis = np.arange(-half, half + 1)
    xs = (axis[:, None] + sub[None, :]).reshape(-1)
    inside = (xs[:, None] ** 2 + xs[None, :] ** 2) <= radius ** 2
    k = inside.reshape(len(axis), 4, len(axis), 4).mean(axis=(1, 3)).astype(np.float32)
    return k / k.sum()


def defocus_levels(max_radius: float) -> list[float]:
    """Blur radii to blur at and interpolate between: 0.5 px apart up to 3, then 20% apart."""
    levels, r = [0.0], 0.5
    while r < max_radius:
        levels.append(r)
        r = r + 0.5 if r < 3 else r * 1.2
    levels.append(max(r, 0.5))
    return levels


def defocus_frame(frame: np.ndarray, radius_px: np.ndarray) -> np.ndarray:
    """Emitted light (H, W, 3) blurred per pixel by a disk of radius_px (H, W): each surface
    point gathers the frame over its circle of confusion. Radii between two levels blend the two
    blurs linearly, so a slowly varying depth gives a smoothly varying blur."""
    import cv2

    radius = np.asarray(radius_px, dtype=np.float32)
    top = float(radius.max()) if radius.size else 0.0
    if top < 0.25:
        return frame
    src = np.ascontiguousarray(frame, dtype=np.float32)
    levels = np.asarray(defocus_levels(top), np.float32)
    index = np.clip(np.searchsorted(levels, radius, side="right") - 1, 0, len(levels) - 2)
    t = np.clip((radius - levels[index]) / (levels[index + 1] - levels[index]), 0.0, 1.0)
    out = np.zeros_like(src)
    for k, level in enumerate(levels):
        w = np.where(index == k, 1.0 - t, 0.0) + np.where(index == k - 1, t, 0.0)
        if not w.any():
            continue
        blurred = src if level == 0 else cv2.filter2D(src, -1, disk_kernel(float(level)),
                                                      borderType=cv2.BORDER_CONSTANT)
        out += blurred * w[..., None].astype(np.float32)
    return out


# -- camera ----------------------------------------------------------------------------------
def vignetting_map(width: int, height: int, half_width_tan: float, strength: float) -> np.ndarray:
    """(H, W) factor of natural vignetting: cos^4 of each pixel's angle off the axis, blended with
    1 by `strength` (0: none). half_width_tan: tan of half the horizontal field of view."""
    x = ((np.arange(width) + 0.5) / width - 0.5) * 2 * half_width_tan
    y = ((np.arange(height) + 0.5) / height - 0.5) * 2 * half_width_tan * height / width
    tan2 = x[None, :] ** 2 + y[:, None] ** 2
    cos4 = 1.0 / (1.0 + tan2) ** 2
    return ((1 - strength) + strength * cos4).astype(np.float32)


# -- inter-reflection ------------------------------------------------------------------------
def _smooth_and_scale_up(low: np.ndarray, size: tuple[int, int], smooth_px: float,
                         low_coverage: np.ndarray | None) -> np.ndarray:
    """A low-resolution (h, w, 3) light, blurred and scaled up to (width, height), both normalised by
    the coverage (so the empty background does not darken it at an outline); 0 where nothing is."""
    import cv2

    light = np.asarray(low, np.float32)
    weight = None if low_coverage is None else np.asarray(low_coverage, np.float32)
    if smooth_px > 0:
        light = cv2.GaussianBlur(light, (0, 0), smooth_px)
        if weight is not None:
            weight = cv2.GaussianBlur(weight, (0, 0), smooth_px)
    width, height = size
    if light.shape[1] != width or light.shape[0] != height:
        light = cv2.resize(light, (width, height), interpolation=cv2.INTER_LINEAR)
        if weight is not None:
            weight = cv2.resize(weight, (width, height), interpolation=cv2.INTER_LINEAR)
    if weight is None:
        return light
    return np.where(weight[..., None] > 1e-3, light / np.maximum(weight, 1e-3)[..., None], 0.0).astype(np.float32)


NORMAL_SIGMA = 0.25  # the normal difference (unit vectors) at which a neighbour's weight falls to e^-1/2
FIT_RIDGE = 0.1  # the first-order fit's slope ridge, relative to the neighbours' total weight


def _unit(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-6)


def _similar(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.exp(-np.sum((a - b) ** 2, axis=-1) / (2 * NORMAL_SIGMA ** 2)).astype(np.float32)


class NormalGuide:
    """A cross-bilateral blur and a joint bilateral upsampling, both guided by the surface normal.

    The bounce light on two walls of a corner differs sharply at the crease: a plain blur carries one
    wall's light onto the other. Here a neighbour counts by its distance (a Gaussian of `smooth_px`
    low-resolution pixels), its coverage and how close its normal is to the pixel's own, at low
    resolution (which averages the path-tracing noise within each surface); then each capture pixel
    takes its four low-resolution neighbours by the bilinear weights times the same normal closeness
    to its own full-size normal.

    With ``first_order`` (the default) the blur is a local linear fit, not a weighted mean: each
    low-resolution pixel takes the value at its own position of the plane that best fits its weighted
    neighbours. Next to a crease a pixel's neighbours all lie on one side of it, and the bounce light
    rises towards a concave crease, so their mean falls short of the light there (by 3-10 % within
    ten pixels of the corner's crease); a plane follows the rise. It also keeps a linear gradient
    whatever the blur's width, so a wider blur takes more of the path-tracing noise away.

    The weights depend on the geometry only (coverage and normals), so one guide serves every frame
    of a capture. low_coverage, low_normal: (h, w), (h, w, 3) as rendered (coverage-weighted); normal:
    (H, W, 3) at the capture's size (width, height)."""

    def __init__(self, low_coverage: np.ndarray, low_normal: np.ndarray, normal: np.ndarray,
                 size: tuple[int, int], smooth_px: float, first_order: bool = True):
        width, height = size
        cov = np.asarray(low_coverage, np.float32)
        h, w = cov.shape
        self.low_shape, self.size = (h, w), (width, height)
        n_low = _unit(np.asarray(low_normal, np.float32) / np.maximum(cov, 1e-6)[..., None])
        sigma = float(smooth_px)
        self.radius = r = int(np.ceil(2 * sigma)) if sigma > 0 else 0
        self.taps = []  # (window, weight (h, w), dx, dy) of the low-resolution blur
        weight = np.zeros((h, w), np.float32)
        moments = np.zeros((h, w, 3, 3), np.float64)  # of (1, dx, dy), for the first-order fit
        # past the frame's edge there is no light: the plane fit pads with nothing there (an edge copy
        # would flatten a gradient that reaches the edge); the mean keeps its edge copies, as before
        self.first_order = bool(first_order) and r > 0
        p_cov, p_n = self._pad(cov, zero=self.first_order), self._pad(n_low)
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                near = np.exp(-(dy * dy + dx * dx) / (2 * sigma * sigma)) if sigma > 0 else 1.0
                if near < 0.01:
                    continue
                window = (slice(r + dy, r + dy + h), slice(r + dx, r + dx + w))
                wgt = (near * _similar(p_n[window], n_low)).astype(np.float32)
                self.taps.append((window, wgt, dx, dy))
                counted = wgt * p_cov[window]
                weight += counted
                if self.first_order:
                    basis = np.array([1.0, dx, dy])
                    moments += counted[..., None, None].astype(np.float64) * np.outer(basis, basis)
        self.inv_weight = np.where(weight > 1e-4, 1.0 / np.maximum(weight, 1e-4), 0.0).astype(np.float32)
        self.fit = None  # (h, w, 3): the fitted plane's value at the pixel = fit . (sum w, sum w dx, sum w dy)
        if self.first_order:
            # a little ridge on the slopes: a sliver of support (one row of pixels) cannot tilt the plane
            moments[..., 1, 1] += FIT_RIDGE * moments[..., 0, 0]
            moments[..., 2, 2] += FIT_RIDGE * moments[..., 0, 0]
            self.fit = (np.linalg.pinv(moments)[..., 0, :] * (weight > 1e-4)[..., None]).astype(np.float32)
        support = cov * (weight > 1e-4)
        n_full = _unit(np.asarray(normal, np.float32))
        u = (np.arange(width, dtype=np.float32) + 0.5) * w / width - 0.5
        v = (np.arange(height, dtype=np.float32) + 0.5) * h / height - 0.5
        u0, v0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
        fu, fv = u - u0, v - v0
        self.corners = []  # (flat low-resolution index (H, W), weight (H, W)) of the four neighbours
        total = np.zeros((height, width), np.float32)
        for oy, by in ((0, 1 - fv), (1, fv)):
            ly = np.clip(v0 + oy, 0, h - 1)
            for ox, bx in ((0, 1 - fu), (1, fu)):
                lx = np.clip(u0 + ox, 0, w - 1)
                flat = ly[:, None] * w + lx[None, :]
                bilinear = (by[:, None] * bx[None, :]) * support.reshape(-1)[flat]
                # (a sliver whose four neighbours all face elsewhere still takes them, bilinearly)
                wgt = (bilinear * (_similar(n_low.reshape(-1, 3)[flat], n_full) + 1e-4)).astype(np.float32)
                self.corners.append((flat, wgt))
                total += wgt
        inv = np.where(total > 1e-6, 1.0 / np.maximum(total, 1e-6), 0.0).astype(np.float32)
        self.corners = [(flat, wgt * inv) for flat, wgt in self.corners]

    def _pad(self, x, zero: bool = False):
        r = self.radius
        return np.pad(x, ((r, r), (r, r)) + ((0, 0),) * (x.ndim - 2), mode="constant" if zero else "edge")

    def scale_up(self, low: np.ndarray) -> np.ndarray:
        """(h, w, C) coverage-weighted light -> (H, W, C), per surface, 0 where no surface is near."""
        light = np.asarray(low, np.float32)
        if light.shape[:2] != self.low_shape:
            raise ValueError(f"the guide is for {self.low_shape[1]}x{self.low_shape[0]} passes, "
                             f"not {light.shape[1]}x{light.shape[0]}")
        padded = self._pad(light, zero=self.fit is not None)
        if self.fit is None:
            blurred = np.zeros_like(light)
            for window, wgt, _, _ in self.taps:
                blurred += wgt[..., None] * padded[window]
            blurred *= self.inv_weight[..., None]
        else:  # the weighted sums of the light, times 1, dx and dy: the plane's value at the pixel
            sums = [np.zeros_like(light) for _ in range(3)]
            for window, wgt, dx, dy in self.taps:
                part = wgt[..., None] * padded[window]
                sums[0] += part
                if dx:
                    sums[1] += dx * part
                if dy:
                    sums[2] += dy * part
            fit = self.fit
            blurred = np.maximum(fit[..., 0:1] * sums[0] + fit[..., 1:2] * sums[1] + fit[..., 2:3] * sums[2], 0.0)
        flat = blurred.reshape(-1, light.shape[-1])
        width, height = self.size
        out = np.zeros((height, width, light.shape[-1]), np.float32)
        for index, wgt in self.corners:
            out += wgt[..., None] * flat[index]
        return out


def indirect_from_passes(with_bounces: np.ndarray, direct: np.ndarray, size: tuple[int, int],
                         smooth_px: float = 1.0, low_coverage: np.ndarray | None = None,
                         coverage: np.ndarray | None = None) -> np.ndarray:
    """The bounce light of a low-resolution pair of renders ('difference' method), at the capture's
    (width, height).

    Both renders use the same samples and seed, so their direct light (and its anti-aliasing)
    is the same and cancels exactly; what is left is the light that bounced. A small blur and a
    bilinear upscale take the rest of its path-tracing noise away. It cannot keep the texture the
    bounce light falls on (see `indirect_from_light_passes`); the converged references use it at full
    size, where it is exact.

    low_coverage (h, w) and coverage (H, W): where the passes and the capture see a surface (the
    renders' alpha): nothing lands off the surface."""
    light = np.asarray(with_bounces, np.float32) - np.asarray(direct, np.float32)
    light = _smooth_and_scale_up(light, size, smooth_px, low_coverage)
    if coverage is not None:
        light = light * np.asarray(coverage, np.float32)[..., None]
    return light


def indirect_from_light_passes(diffuse_irradiance: np.ndarray, other_indirect: np.ndarray | None,
                               albedo: np.ndarray, size: tuple[int, int], smooth_px: float = 1.0,
                               low_coverage: np.ndarray | None = None,
                               coverage: np.ndarray | None = None, guide: NormalGuide | None = None) -> np.ndarray:
    """The bounce light from one low-resolution render's light-path passes ('passes' method).

    diffuse_irradiance (h, w, 3): Cycles' Diffuse Indirect pass, the bounced light arriving at
    diffuse surfaces before their colour is applied. It is smooth (what varies at a few pixels is the
    surface's texture, which the pass leaves out), so it is blurred and scaled up, then multiplied by
    the full-size albedo (H, W, 3; the Diffuse Color pass): the bounce light keeps the texture it
    falls on. other_indirect (h, w, 3): the glossy, transmitted and subsurface bounce light, colour
    included, blurred and scaled up as it is. With a NormalGuide (the surface normals, low and full
    size) the blur and the scale-up stop at creases."""
    albedo = np.asarray(albedo, np.float32)
    width, height = size
    if albedo.shape[:2] != (height, width):
        raise ValueError(f"the albedo pass is {albedo.shape[1]}x{albedo.shape[0]}, the capture {width}x{height}")
    def scale_up(x):
        return guide.scale_up(x) if guide is not None else _smooth_and_scale_up(x, size, smooth_px, low_coverage)

    if other_indirect is not None and not np.any(other_indirect):
        other_indirect = None  # matte surfaces: only diffuse light bounces
    if other_indirect is not None:  # one pass over both
        both = scale_up(np.concatenate([diffuse_irradiance, other_indirect], axis=-1))
        light, other = albedo * both[..., :3], both[..., 3:]
    else:
        light = albedo * scale_up(diffuse_irradiance)
    if other_indirect is not None:
        if coverage is not None:
            other = other * np.asarray(coverage, np.float32)[..., None]
        light = light + other
    return light.astype(np.float32)
