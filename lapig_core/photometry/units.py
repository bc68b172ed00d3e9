"""The projector's light in photometric units, and the one lumens <-> Blender watts conversion.

Derivation (checked by `bench light`, tools/bench/bench_light.py):

- Blender's light power is radiometric watts at 683 lm/W, and a spot light's power is given as if it
  were a point light's: its radiant intensity is W / 4pi W/sr in every direction of its cone, whatever
  the cone's size (narrowing it does not concentrate the power).
- LAPIG's projector light (lapig_addon/blender/projector_nodes.py) multiplies that intensity by the
  projected image's value in the ray's direction: the image is a Non-Color texture of *relative
  emitted light* (ProjectorModel.emitted: gamma, then black level), read raw with Emission strength 1,
  so a white frame is 1.0 in every pixel and nothing normalises the texture. The intensity towards
  projector pixel p is therefore I(p) = 683 * W * e(p) / (4pi) candela.
- A pinhole of uniform intensity I lights a plane at distance d, at normal incidence, with
  E = I cos^3(theta) / d^2 (inverse square times the cosine of incidence, theta off the axis).
- ANSI lumens F are the mean of nine illuminance readings (the centres of a 3 x 3 grid over the image)
  times the image area A = A1 d^2, A1 the image's area at unit distance. So F = A1 I m9, m9 the mean of
  cos^3 at those nine points, and

      W = 4pi F / (683 A1 m9 mean(e_white)).

  The flux form of the issue, W = 4pi F / (683 Omega), Omega the frustum's solid angle
  (= A1 * the area mean of cos^3), puts all F lumens into the frustum; it differs from the ANSI form
  by m9 / area-mean(cos^3): 0.8% at throw ratio 1.5 and 4:3 (frustum_solid_angle, ansi_cos3_mean).
  The ANSI form is the one a light meter on the nine points confirms, so it is the default.
- A render's linear pixel value (Raw or Standard view, exposure 0) is radiance in W/m2/sr; a
  Lambertian surface of albedo rho under illuminance E (W/m2) shows rho E / pi, so
  E[lux] = 683 pi v / rho, and Cycles' Diffuse Direct pass (the light without the albedo) is E / pi:
  E[lux] = 683 pi * pass. A Sun light's strength is its illuminance in W/m2 (the bench checks both).
"""
from __future__ import annotations

import math

import numpy as np

LUMENS_PER_WATT = 683.0
# Rec. 709 luminance weights: the photometric weight of a linear RGB light
LUMA = np.array([0.2126, 0.7152, 0.0722])
PLANNING_MIN_CONTRAST = 5.0  # the practitioners' planning minimum
PLANNING_GOOD_CONTRAST = 10.0


class LightUnitError(ValueError):
    """A value no light can have (lumens <= 0, negative lux): the message says which and why."""


def check_lumens(lumens: float) -> float:
    lumens = float(lumens)
    if not math.isfinite(lumens) or lumens <= 0:
        raise LightUnitError(f"projector brightness must be more than 0 lumens, got {lumens:g}")
    return lumens


def check_lux(lux: float, what: str = "ambient illuminance") -> float:
    lux = float(lux)
    if not math.isfinite(lux) or lux < 0:
        raise LightUnitError(f"{what} must be 0 lux or more, got {lux:g}")
    return lux


def _bounds(model) -> tuple[float, float, float, float]:
    """The image's edges on the plane at unit distance (x right, y up), lens shift included."""
    sx, sy = model.uv_scale()
    return ((-0.5 - model.shift_x) / sx, (0.5 - model.shift_x) / sx,
            (-0.5 - model.shift_y) / sy, (0.5 - model.shift_y) / sy)


def image_area_at_unit_distance(model) -> float:
    x0, x1, y0, y1 = _bounds(model)
    return (x1 - x0) * (y1 - y0)


def frustum_solid_angle(model) -> float:
    """The solid angle (sr) of the projector's image rectangle, lens shift included (exact)."""
    def corner(x, y):
        return math.atan2(x * y, math.sqrt(1 + x * x + y * y))
    x0, x1, y0, y1 = _bounds(model)
    return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0)


def _cos3(x, y):
    return (1.0 + np.square(x) + np.square(y)) ** -1.5


def ansi_points(model) -> np.ndarray:
    """(9, 2) the ANSI points (centres of a 3 x 3 grid) as (x, y) on the plane at unit distance."""
    x0, x1, y0, y1 = _bounds(model)
    t = np.array([1 / 6, 1 / 2, 5 / 6])
    xs, ys = np.meshgrid(x0 + t * (x1 - x0), y0 + t * (y1 - y0))
    return np.stack([xs.ravel(), ys.ravel()], -1)


def ansi_cos3_mean(model) -> float:
    p = ansi_points(model)
    return float(_cos3(p[:, 0], p[:, 1]).mean())


def lumens_to_watts(lumens: float, model, white_mean: float = 1.0, rule: str = "ansi") -> float:
    """The Blender light power (W) of a projector of `lumens` ANSI lumens (see the module's derivation).

    white_mean: the mean relative emitted light of the frame that is the projector's white (1.0 for
    LAPIG's light, which emits ProjectorModel.emitted values raw). rule 'ansi' (default) matches the
    nine-point meter reading; 'flux' puts all the lumens into the frustum (4pi F / (683 Omega))."""
    lumens = check_lumens(lumens)
    if not white_mean > 0:
        raise LightUnitError(f"the white image's mean must be more than 0, got {white_mean:g}")
    if rule == "ansi":
        per_sr = image_area_at_unit_distance(model) * ansi_cos3_mean(model)
    elif rule == "flux":
        per_sr = frustum_solid_angle(model)
    else:
        raise LightUnitError(f"unknown conversion rule '{rule}' (ansi or flux)")
    return 4 * math.pi * lumens / (LUMENS_PER_WATT * per_sr * white_mean)


def watts_to_lumens(watts: float, model, white_mean: float = 1.0, rule: str = "ansi") -> float:
    """The inverse of lumens_to_watts: the ANSI lumens a Blender light of `watts` W stands for."""
    if not watts > 0:
        raise LightUnitError(f"the light's power must be more than 0 W, got {watts:g}")
    return watts * lumens_to_watts(1.0, model, white_mean, rule) ** -1


def planning_illuminance(lumens: float, area_m2: float, incidence_deg: float = 0.0) -> float:
    """The planner's E = lumens / lit area x cos(incidence), in lux."""
    check_lumens(lumens)
    if not area_m2 > 0:
        raise LightUnitError(f"the lit area must be more than 0 m2, got {area_m2:g}")
    return lumens / area_m2 * math.cos(math.radians(incidence_deg))


def image_area_m2(model, distance_m: float) -> float:
    """The image's area (m2) on a plane square to the axis at `distance_m`."""
    return image_area_at_unit_distance(model) * distance_m ** 2


def lux_from_radiance(pixel, albedo):
    """Illuminance (lux) on a Lambertian surface of `albedo` whose linear render value is `pixel`."""
    return LUMENS_PER_WATT * math.pi * np.asarray(pixel, np.float64) / np.asarray(albedo, np.float64)


def lux_from_diffuse_direct(diffuse_direct):
    """Illuminance (lux) from Cycles' Diffuse Direct pass (linear, albedo-free): E = 683 pi pass."""
    d = np.asarray(diffuse_direct, np.float64)
    if d.ndim == 3 and d.shape[-1] >= 3:
        d = d[..., :3] @ LUMA
    return LUMENS_PER_WATT * math.pi * d


def luminance_cd_m2(albedo, lux):
    """Luminance (cd/m2) of a matte surface: L = rho E / pi."""
    return np.asarray(albedo, np.float64) * np.asarray(lux, np.float64) / math.pi


def sun_strength_for_lux(lux: float) -> float:
    """A Sun light's strength (W/m2) that gives `lux` on a surface facing it."""
    return check_lux(lux) / LUMENS_PER_WATT


def world_strength_for_lux(lux: float) -> float:
    """A uniform world's strength (its radiance) that gives `lux` on an unoccluded surface: E = pi L."""
    return check_lux(lux) / (LUMENS_PER_WATT * math.pi)


def black_level_from_contrast(contrast: float) -> float:
    """A projector's black relative to its white: 1 / contrast ratio."""
    contrast = float(contrast)
    if not contrast > 1:
        raise LightUnitError(f"a contrast ratio must be more than 1:1, got {contrast:g}")
    return 1.0 / contrast


def contrast_ratio(white_lux, ambient_lux, projector_contrast: float | None = None):
    """(projected white + ambient) / (projected black + ambient) on the same surface; the projector's
    own black is white / its contrast (None: a perfect black, the planning formula)."""
    w = np.asarray(white_lux, np.float64)
    a = np.asarray(ambient_lux, np.float64)
    black = w / projector_contrast if projector_contrast else 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        return (w + a) / (black + a)


def white_lux_for_contrast(target: float, ambient_lux: float, projector_contrast: float | None = None) -> float:
    """The projected white (lux) that reaches `target`:1 against `ambient_lux`; inf when the projector's
    own contrast is below the target."""
    if target <= 1:
        return 0.0
    loss = 1.0 - (target / projector_contrast if projector_contrast else 0.0)
    if loss <= 0:
        return math.inf
    return (target - 1.0) * ambient_lux / loss


def ambient_lux_for_contrast(target: float, white_lux: float, projector_contrast: float | None = None) -> float:
    """The most ambient light (lux) that keeps `target`:1 with `white_lux` projected."""
    loss = 1.0 - (target / projector_contrast if projector_contrast else 0.0)
    if loss <= 0:
        return 0.0
    return max(0.0, white_lux * loss / (target - 1.0))
