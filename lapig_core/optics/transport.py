# SPDX-License-Identifier: GPL-3.0-or-later
"""How light travels in a capture: bounces, the projector's and the camera's lenses, vignetting.

Two modes. FAST is direct light through pinhole lenses (what the classical per-pixel model
assumes; quick to iterate). REALISTIC adds what a real room and real lenses do:
  * diffuse (and glossy) inter-reflection, rendered as a separate indirect pass (see
    `indirect_from_passes`);
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


@dataclass(frozen=True)
class LightTransport:
    mode: str = "REALISTIC"
    bounces: int = 3  # diffuse / glossy / transmission bounces of the indirect pass
    indirect_samples: int = 16  # samples per pixel of the indirect pass
    indirect_downscale: int = 4  # the indirect pass renders at 1/this of the capture size
    indirect_smooth_px: float = 1.5  # Gaussian sigma on the low-resolution bounce light (0: raw; references)
    bounce_albedo_guide: bool = True  # the full-size albedo puts back the texture the bounce light falls on
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
        return ["REALISTIC", self.bounces, self.indirect_samples, self.indirect_downscale, self.indirect_smooth_px,
                round(self.projector_focus_m, 4), round(self.projector_lens_radius_mm, 4),
                self.camera_dof, round(self.camera_focus_m, 4), round(self.camera_f_number, 3),
                self.camera_dof_samples, round(self.vignetting, 4), self.subsurface_samples,
                self.bounce_albedo_guide]

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
def indirect_from_passes(with_bounces: np.ndarray, direct: np.ndarray, size: tuple[int, int],
                         smooth_px: float = 1.0, low_coverage: np.ndarray | None = None,
                         coverage: np.ndarray | None = None, albedo: np.ndarray | None = None) -> np.ndarray:
    """The bounce light of a low-resolution pass, at the capture's (width, height).

    Both passes render at the same samples and seed, so their direct light (and its anti-aliasing)
    is the same and cancels exactly; what is left is the light that bounced. It is smooth, so a
    small blur and a bilinear upscale take the rest of its path-tracing noise away without
    softening anything the direct pass carries (edges, texture, highlights of the projector).

    low_coverage (h, w) and coverage (H, W): where the passes and the capture see a surface (the
    renders' alpha). The blur and the upscale are then normalised by coverage, so the empty
    background does not darken the bounce light at the object's outline, and nothing lands off it.

    albedo (H, W, 3): the surface's diffuse colour at the capture's size (Cycles' Diffuse Color pass).
    Bounce light is the albedo times a smooth irradiance, so with it the low-resolution pass gives only
    the irradiance (its light over its area-averaged albedo) and the full-size albedo puts back the
    texture the bounced light falls on, which a low-resolution pass alone smooths away. Where the
    surface has almost no diffuse colour (black, or gloss only) the unguided bounce light is kept."""
    import cv2

    if albedo is not None:
        return _albedo_guided(with_bounces, direct, size, smooth_px, low_coverage, coverage, albedo)

    indirect = np.asarray(with_bounces, np.float32) - np.asarray(direct, np.float32)
    weight = None if low_coverage is None else np.asarray(low_coverage, np.float32)[..., None]
    if weight is not None:
        indirect = indirect * weight
    if smooth_px > 0:
        indirect = cv2.GaussianBlur(indirect, (0, 0), smooth_px)
        if weight is not None:
            weight = cv2.GaussianBlur(weight[..., 0], (0, 0), smooth_px)[..., None]
    width, height = size
    if indirect.shape[1] != width or indirect.shape[0] != height:
        indirect = cv2.resize(indirect, (width, height), interpolation=cv2.INTER_LINEAR)
        if weight is not None:
            weight = cv2.resize(weight[..., 0], (width, height), interpolation=cv2.INTER_LINEAR)[..., None]
    if weight is not None:
        indirect = np.where(weight > 1e-3, indirect / np.maximum(weight, 1e-3), 0.0).astype(np.float32)
    if coverage is not None:
        indirect = indirect * np.asarray(coverage, np.float32)[..., None]
    return indirect


GUIDE_MIN_ALBEDO = 0.02  # below this diffuse colour the bounce light is mostly gloss: not guided


def _albedo_guided(with_bounces, direct, size, smooth_px, low_coverage, coverage, albedo) -> np.ndarray:
    import cv2

    unguided = indirect_from_passes(with_bounces, direct, size, smooth_px, low_coverage, coverage)
    albedo = np.asarray(albedo, np.float32)
    width, height = size
    if albedo.shape[:2] != (height, width):
        raise ValueError(f"the albedo pass is {albedo.shape[1]}x{albedo.shape[0]}, the capture {width}x{height}")
    bounce = np.asarray(with_bounces, np.float32) - np.asarray(direct, np.float32)
    low_h, low_w = bounce.shape[:2]
    # both carry the pixels' coverage (the film is transparent off the surface), so their ratio does not
    low_albedo = cv2.resize(albedo, (low_w, low_h), interpolation=cv2.INTER_AREA)
    if smooth_px > 0:
        bounce = cv2.GaussianBlur(bounce, (0, 0), smooth_px)
        low_albedo = cv2.GaussianBlur(low_albedo, (0, 0), smooth_px)
    guided_here = low_albedo > GUIDE_MIN_ALBEDO
    irradiance = np.where(guided_here, bounce / np.maximum(low_albedo, GUIDE_MIN_ALBEDO), 0.0).astype(np.float32)
    irradiance = cv2.resize(irradiance, (width, height), interpolation=cv2.INTER_LINEAR)
    guided_here = cv2.resize(guided_here.astype(np.float32), (width, height), interpolation=cv2.INTER_LINEAR)
    guided = albedo * irradiance
    return (guided_here * guided + (1 - guided_here) * unguided).astype(np.float32)
