"""Colour grading and the mood grades (night, dusk, dawn, golden hour, bright, dark, fog, vintage, winter).

One grade: exposure and gamma, saturation, a split tone (shadow tint and highlight tint multiplied in
along the luminance) and a haze towards a light grey. A mood is this grade with its own start values;
PSA moves them like any other parameter.
"""
from __future__ import annotations


from .ops import luminance, saturate
from .stage import Stage, tensor

SCALES = {"exposure": 0.3, "gamma": 0.3, "saturation": 0.3, "shadow_tint": 0.2, "highlight_tint": 0.2,
          "haze": 0.2}


def grade(x, p, surface=None):
    y = x.clamp(1e-4, 1.0) ** p["gamma"].clamp(0.2, 5.0) * p["exposure"]
    y = saturate(y, p["saturation"])
    lum = luminance(y).clamp(0, 1)
    tint = p["shadow_tint"].view(1, 3, 1, 1) * (1 - lum) + p["highlight_tint"].view(1, 3, 1, 1) * lum
    y = y * tint
    haze = p["haze"].clamp(0, 1)
    return y * (1 - haze) + haze * 0.82


# exposure, gamma, saturation, shadow tint, highlight tint, haze
MOODS = {
    "neutral_grade": (1.0, 1.0, 1.0, (1.0, 1.0, 1.0), (1.0, 1.0, 1.0), 0.0),
    "night": (0.55, 1.35, 0.6, (0.35, 0.45, 0.9), (0.6, 0.72, 1.0), 0.0),
    "dusk": (0.8, 1.1, 1.15, (0.6, 0.35, 0.7), (1.12, 0.72, 0.48), 0.0),
    "dawn": (1.02, 0.9, 0.95, (0.8, 0.68, 0.88), (1.1, 0.92, 0.82), 0.04),
    "golden_hour": (1.05, 0.95, 1.15, (0.82, 0.58, 0.42), (1.15, 0.95, 0.62), 0.0),
    "bright_sunny": (1.12, 0.8, 1.2, (1.0, 1.0, 0.95), (1.06, 1.03, 0.94), 0.02),
    "dark_moody": (0.62, 1.35, 0.55, (0.55, 0.55, 0.6), (0.85, 0.84, 0.88), 0.0),
    "foggy": (1.0, 0.9, 0.55, (0.9, 0.93, 0.97), (0.97, 0.98, 1.0), 0.38),
    "vintage_faded": (1.0, 0.95, 0.62, (0.85, 0.72, 0.6), (1.06, 0.96, 0.8), 0.12),
    "wintry": (1.05, 0.9, 0.75, (0.75, 0.86, 1.05), (0.95, 1.0, 1.08), 0.05),
}


def grade_stage(look: str, role: str = "mood") -> Stage:
    exposure, gamma, sat, shadow, highlight, haze = MOODS[look]
    params = {"exposure": tensor(exposure), "gamma": tensor(gamma), "saturation": tensor(sat),
              "shadow_tint": tensor(shadow), "highlight_tint": tensor(highlight), "haze": tensor(haze)}
    return Stage(look, role, grade, params, dict(SCALES))
