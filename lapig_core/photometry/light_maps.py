"""What the viewer sees in physical units, from per-sample light maps: the summary and colour maps.

Inputs are maps over the same samples (projector pixels, or camera pixels): the illuminance a white
frame gives (lux), the room's (lux), the surface's albedo, and the frame's relative emitted light; a
valid mask says which samples are on the object. Light adds linearly, so the frame's illuminance is
white x emitted, exact for direct light (bounce light is not in the white map)."""
from __future__ import annotations

import math

import numpy as np

from .units import (PLANNING_GOOD_CONTRAST, PLANNING_MIN_CONTRAST, ambient_lux_for_contrast, contrast_ratio,
                    luminance_cd_m2, white_lux_for_contrast)

COVERED_SHARE = 0.95  # the fixes aim at this share of the object
LAMP_HEADROOM = 0.7  # lamps fade: planners buy 25-30% more lumens than the first day needs (NOTES section 10)


def _stats(values: np.ndarray) -> dict:
    if values.size == 0:
        return {"mean": None, "min": None, "max": None, "p05": None}
    return {"mean": round(float(values.mean()), 2), "min": round(float(values.min()), 2),
            "max": round(float(values.max()), 2), "p05": round(float(np.percentile(values, 5)), 2)}


MAX_CONTRAST = 1e6  # a dark room and a perfect black: reported as this, not as infinity


def finite_contrast(c: np.ndarray) -> np.ndarray:
    """No light at all (0 / 0) is 1:1; light against no light at all is MAX_CONTRAST:1."""
    c = np.asarray(c, np.float64)
    return np.where(np.isnan(c), 1.0, np.minimum(c, MAX_CONTRAST))


def light_summary(white_lux, ambient_lux, albedo, emitted, valid, lumens: float,
                  projector_contrast: float | None = None) -> dict:
    """The figures of the look on the object and the warning with its fixes.

    white_lux: the illuminance of a white frame; emitted: the frame's relative emitted light (its
    luminance share of white, black level included); projector_contrast: for the black level."""
    valid = np.asarray(valid, bool)
    if not valid.any():
        raise ValueError("the projector reaches none of the object: nothing to report")
    white = np.asarray(white_lux, np.float64)
    ambient = np.broadcast_to(np.asarray(ambient_lux, np.float64), white.shape)
    look = white * np.asarray(emitted, np.float64)
    total = look + ambient
    lum = luminance_cd_m2(np.broadcast_to(albedo, white.shape), total)
    rig_contrast = finite_contrast(contrast_ratio(white, ambient, projector_contrast))
    w, a, c = white[valid], ambient[valid], rig_contrast[valid]
    below = float((c < PLANNING_MIN_CONTRAST).mean())
    # the fixes, for the dimmer part of the object (COVERED_SHARE of it reaches the target)
    w_low = float(np.percentile(w, 100 * (1 - COVERED_SHARE)))
    a_high = float(np.percentile(a, 100 * COVERED_SHARE))
    fixes = {}
    for target in (PLANNING_MIN_CONTRAST, PLANNING_GOOD_CONTRAST):
        need = white_lux_for_contrast(target, a_high, projector_contrast)
        fixes[f"lumens_for_{int(target)}_to_1"] = (None if not math.isfinite(need) else
                                                   round(lumens * need / max(w_low, 1e-9)))
        fixes[f"lumens_for_{int(target)}_to_1_with_headroom"] = (
            None if not math.isfinite(need) else round(lumens * need / max(w_low, 1e-9) / LAMP_HEADROOM))
        fixes[f"ambient_lux_for_{int(target)}_to_1"] = round(ambient_lux_for_contrast(target, w_low,
                                                                                      projector_contrast), 1)
    summary = {"lumens": lumens, "projector_contrast": projector_contrast,
               "white_lux": _stats(w), "ambient_lux": _stats(a), "look_lux": _stats(look[valid]),
               "total_lux": _stats(total[valid]), "luminance_cd_m2": _stats(lum[valid]),
               "contrast_ratio": {**_stats(c), "median": round(float(np.median(c)), 2)},
               "contrast_below_5_share": round(below, 4), "fixes": fixes}
    summary["warning"] = contrast_warning(below, fixes)
    return summary


def contrast_warning(below_share: float, fixes: dict) -> str:
    """'' when the object keeps 5:1; else where it falls below and what would fix it."""
    if below_share <= 1 - COVERED_SHARE:
        return ""
    five, ten = fixes.get("lumens_for_5_to_1"), fixes.get("lumens_for_10_to_1")
    lumens = (f"about {five:,} lumens for 5:1 ({ten:,} for 10:1)" if five and ten else
              f"about {five:,} lumens for 5:1" if five else "a projector of higher contrast")
    return (f"{below_share:.0%} of the object is below 5:1 against the room's light: the look will wash out "
            f"there. Use {lumens}, dim the room to {fixes.get('ambient_lux_for_5_to_1')} lux or less, or "
            f"choose a darker look, whose shadows matter less")


def repair_dropouts(lux: np.ndarray, threshold: float = 0.9) -> np.ndarray:
    """Cycles now and then loses a shadow ray that grazes the shared edge of two triangles, so one of a
    pixel's samples goes dark along a mesh's edges (a faint dotted line, 25% dips at 4 samples). A pixel
    below `threshold` x the median of its 3 x 3 neighbourhood, with every neighbour lit, takes that
    median: it can only raise a value, which keeps the dose figures on the safe side; a real shadow's
    edge has dark neighbours and is left alone."""
    if min(lux.shape) < 3:
        return lux
    padded = np.pad(lux, 1, mode="edge")
    h, w = lux.shape
    stack = np.stack([padded[y:y + h, x:x + w] for y in range(3) for x in range(3)])
    median = np.median(stack, axis=0)
    lit_around = (np.delete(stack, 4, axis=0) > threshold * median).sum(0) >= 7
    return np.where((lux < threshold * median) & lit_around, median, lux)


# -- colour maps ---------------------------------------------------------------------------------------
_RAMP = np.array([[0.00, 0.00, 0.02], [0.25, 0.05, 0.45], [0.70, 0.15, 0.40], [0.98, 0.55, 0.05],
                  [0.99, 0.98, 0.65]])


def _ramp(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(t.astype(int), len(_RAMP) - 2)
    f = (t - i)[..., None]
    return _RAMP[i] * (1 - f) + _RAMP[i + 1] * f


def lux_colour_map(lux: np.ndarray, valid: np.ndarray, low: float = 1.0, high: float = 10_000.0) -> np.ndarray:
    """Float RGB in [0, 1]: log10 lux from `low` (dark) to `high` (pale yellow); grey off the object."""
    t = (np.log10(np.maximum(np.asarray(lux, np.float64), low)) - math.log10(low)) / math.log10(high / low)
    rgb = _ramp(t)
    rgb[~np.asarray(valid, bool)] = 0.25
    return rgb.astype(np.float32)


def contrast_colour_map(contrast: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Red below 5:1 (deeper the lower), amber from 5:1 to 10:1, green above; grey off the object."""
    c = np.asarray(contrast, np.float64)
    rgb = np.empty(c.shape + (3,))
    low = np.clip((c - 1) / (PLANNING_MIN_CONTRAST - 1), 0, 1)[..., None]
    rgb[:] = np.array([0.35, 0.0, 0.0]) * (1 - low) + np.array([0.95, 0.1, 0.05]) * low
    mid = (c >= PLANNING_MIN_CONTRAST) & (c < PLANNING_GOOD_CONTRAST)
    rgb[mid] = (0.98, 0.7, 0.1)
    rgb[c >= PLANNING_GOOD_CONTRAST] = (0.15, 0.75, 0.3)
    rgb[~np.asarray(valid, bool)] = 0.25
    return rgb.astype(np.float32)
