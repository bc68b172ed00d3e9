"""The light-dose guard: a conservation category, a show schedule, the dose figures, the cap.

Categories (CIE 157 style, as museum guidance quotes them; see NOTES section 10):
- 'high' (highly light-sensitive: works on paper, textiles, watercolours): 50 lux, 150,000 lux.h a year;
- 'moderate' (moderately sensitive: oil paintings, wood, horn): 200 lux, 600,000 lux.h a year;
- 'custom': a lux limit of the designer's; its yearly budget is that limit over the schedule.
Damage scales with lux x hours, so the yearly figure is reported against the category's budget as well
as the maximum lux against the limit.

The cap limits the projector image: light on a surface is linear in the projector's emitted light, so
where a projector pixel lands on the marked region its emitted light may be at most
(limit - ambient) / (the lux a white pixel gives there). cap_input_luminance (the one the product uses)
holds the pixel's luminance to that with the least change of its light; cap_input holds each channel
(stricter: it dims a saturated blue that adds little to the lux). Either rounds the input values down to
the bit depth's steps (the inverse of ProjectorModel.emitted), so the quantised frame stays under the cap.
On the bench's case both reach 49.5 lux under a 50 lux limit; the luminance cap costs 13.79 dB of PSNR
against the free look's target, the per-channel one 15.34 dB.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .units import LightUnitError, check_lux

CATEGORIES = {  # name: (lux limit, yearly lux-hours budget, what it is for)
    "high": (50.0, 150_000.0, "highly light-sensitive (paper, textiles, watercolour)"),
    "moderate": (200.0, 600_000.0, "moderately light-sensitive (oil paint, wood, horn)"),
}


class DoseError(LightUnitError):
    """A schedule or a limit no show can have."""


@dataclass(frozen=True)
class Schedule:
    hours_per_day: float = 8.0
    days_per_year: float = 300.0

    def problem(self) -> str:
        h, d = self.hours_per_day, self.days_per_year
        if not (math.isfinite(h) and 0 < h <= 24):
            return f"the show schedule's hours per day must be more than 0 and at most 24, got {h:g}"
        if not (math.isfinite(d) and 0 < d <= 366):
            return f"the show schedule's days per year must be more than 0 and at most 366, got {d:g}"
        return ""

    @property
    def hours_per_year(self) -> float:
        return self.hours_per_day * self.days_per_year


@dataclass(frozen=True)
class ConservationLimit:
    category: str = "high"  # 'high', 'moderate' or 'custom'
    custom_lux: float = 50.0
    schedule: Schedule = Schedule()

    def problem(self) -> str:
        if self.category not in CATEGORIES and self.category != "custom":
            return f"unknown conservation category '{self.category}' (high, moderate or custom)"
        if self.category == "custom" and not (math.isfinite(self.custom_lux) and self.custom_lux > 0):
            return f"a custom light limit must be more than 0 lux, got {self.custom_lux:g}"
        return self.schedule.problem()

    def check(self) -> "ConservationLimit":
        problem = self.problem()
        if problem:
            raise DoseError(problem)
        return self

    @property
    def limit_lux(self) -> float:
        return self.custom_lux if self.category == "custom" else CATEGORIES[self.category][0]

    @property
    def yearly_budget_lux_h(self) -> float:
        if self.category == "custom":
            return self.custom_lux * self.schedule.hours_per_year
        return CATEGORIES[self.category][1]


def dose_figures(total_lux: np.ndarray, region: np.ndarray, limit: ConservationLimit,
                 weights: np.ndarray | None = None) -> dict:
    """Max and mean lux on the region, lux-hours a year (at the mean and at the brightest point), and
    whether each stays within the limit. weights: the surface area each sample stands for (None: equal)."""
    limit.check()
    region = np.asarray(region, bool)
    if not region.any():
        raise DoseError("the marked region has no faces the projector reaches: mark faces it lights, or "
                        "the whole object")
    lux = np.asarray(total_lux, np.float64)[region]
    if (lux < -1e-9).any():
        raise DoseError("negative illuminance on the region: the light maps are wrong")
    w = np.ones_like(lux) if weights is None else np.asarray(weights, np.float64)[region]
    mean = float((lux * w).sum() / max(w.sum(), 1e-12))
    peak = float(lux.max())
    hours = limit.schedule.hours_per_year
    budget = limit.yearly_budget_lux_h
    return {"category": limit.category, "limit_lux": limit.limit_lux, "max_lux": round(peak, 2),
            "mean_lux": round(mean, 2), "hours_per_day": limit.schedule.hours_per_day,
            "days_per_year": limit.schedule.days_per_year,
            "lux_hours_per_year_mean": round(mean * hours), "lux_hours_per_year_max": round(peak * hours),
            "yearly_budget_lux_hours": round(budget), "within_limit": peak <= limit.limit_lux + 1e-6,
            "within_yearly_budget": peak * hours <= budget + 1e-6,
            "share_over_limit": round(float((lux > limit.limit_lux + 1e-6).mean()), 4)}


def emitted_cap(white_lux: np.ndarray, ambient_lux: np.ndarray, region: np.ndarray, limit_lux: float,
                black_level: float = 0.0, margin: float = 0.0) -> tuple[np.ndarray, dict]:
    """The most relative emitted light each projector pixel may send (1 off the region), and what the
    cap cannot do: where the room light alone, or the projector's black, is over the limit."""
    check_lux(limit_lux, "the light limit")
    white = np.asarray(white_lux, np.float64)
    ambient = np.broadcast_to(np.asarray(ambient_lux, np.float64), white.shape)
    region = np.asarray(region, bool)
    budget = limit_lux * (1.0 - margin) - ambient
    with np.errstate(divide="ignore", invalid="ignore"):
        cap = np.where(white > 1e-12, budget / white, np.inf)
    cap = np.where(region, np.clip(cap, 0.0, 1.0), 1.0)
    room_over = region & (ambient > limit_lux)
    black_over = region & (white * black_level + ambient > limit_lux)
    return cap, {"room_light_over_limit_share": round(float(room_over.sum() / max(region.sum(), 1)), 4),
                 "projector_black_over_limit_share": round(float(black_over.sum() / max(region.sum(), 1)), 4)}


def cap_input(frame: np.ndarray, cap: np.ndarray, gamma: float, black_level: float, bit_depth: int = 8) -> np.ndarray:
    """Projector input values (float in [0, 1], H x W x 3) limited so emitted light stays under `cap`
    (H x W): the inverse of ProjectorModel.emitted, rounded down to the bit depth's steps."""
    frame = np.asarray(frame, np.float64)
    c = np.asarray(cap, np.float64)[..., None]
    rel = np.clip((c - black_level) / max(1.0 - black_level, 1e-12), 0.0, 1.0)
    top = np.power(rel, 1.0 / gamma)
    steps = 2 ** bit_depth - 1
    top = np.floor(top * steps + 1e-9) / steps
    return np.minimum(frame, top)


def cap_input_luminance(frame: np.ndarray, cap: np.ndarray, gamma: float, black_level: float,
                        bit_depth: int = 8, weights=(0.2126, 0.7152, 0.0722)) -> np.ndarray:
    """Like cap_input, but the cap holds the pixel's luminance (what a lux meter reads), not each channel:
    the emitted light moves the least distance (L2) to luminance <= cap, e' = clip(e - lambda w, black, 1),
    lambda by bisection; then back to input values, rounded down to the bit depth's steps."""
    frame = np.asarray(frame, np.float64)
    w = np.asarray(weights, np.float64)
    e = black_level + (1.0 - black_level) * np.power(np.clip(frame, 0, 1), gamma)
    c = np.asarray(cap, np.float64)
    over = (e @ w) > c
    if over.any():
        eo, co = e[over], c[over][:, None]
        lo, hi = np.zeros((len(eo), 1)), np.full((len(eo), 1), float(e.max() / w.min() + 1))
        for _ in range(40):
            mid = (lo + hi) / 2
            fits = (np.clip(eo - mid * w, black_level, 1.0) @ w)[:, None] <= co
            hi, lo = np.where(fits, mid, hi), np.where(fits, lo, mid)
        e = e.copy()
        e[over] = np.clip(eo - hi * w, black_level, 1.0)
    rel = np.clip((e - black_level) / max(1.0 - black_level, 1e-12), 0.0, 1.0)
    steps = 2 ** bit_depth - 1
    capped = np.floor(np.power(rel, 1.0 / gamma) * steps + 1e-9) / steps
    return np.where(over[..., None], np.minimum(capped, frame), frame)
