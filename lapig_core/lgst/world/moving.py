# SPDX-License-Identifier: GPL-3.0-or-later
"""The time of a world look (issue 50, item 5): water flows, fire flickers, clouds drift, plants sway and grow, light
plays over stone and metal. Each family moves its own way; the stage draws the look again at time t.

    flow     the pattern carried along a direction (water, waterfalls, falling snow, rising bubbles, drifting sky):
             two copies of it, half a loop apart, each carried and faded in as the other fades out (the flow-map
             trick of games' water), so the motion runs on for ever and loops with the show's period
    flicker  the coordinates warped by noise that turns on a circle in noise space (fire, caustics, underwater)
    sway     the same, gentler and slower, and the growth's density rising and falling over the loop (plants)
    sheen    the pattern stays; a broad light passes over it (stone, metal, wood, fabric, glass, made things)

Every motion is the still look at t = 0 exactly (one copy, no warp, no light), periodic in the clock's period
(a show's looped hold shows no jump), and a small change for a small step of time. The speed parameter scales how
fast (0: still); whole loops per period keep it periodic.

Adding a generator's motion: its family's in FAMILY_MOTION, or its pattern's or material's in PATTERN_MOTION /
MATERIAL_MOTION (a kind above and, for a flow, its direction in the image and features per second)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import noise


@dataclass(frozen=True)
class Clock:
    """Where the look is in time: t seconds into a loop of `period` seconds, at `speed` (the parameter)."""
    t: float = 0.0
    period: float = 4.0
    speed: float = 1.0

    def still(self) -> bool:
        return self.t == 0.0 or self.speed <= 0.0

    def loops(self, per_second: float) -> int:
        """Whole loops per period for a motion of `per_second` loops a second at speed 1 (at least one)."""
        return max(1, round(per_second * self.speed * self.period))

    def angle(self, per_second: float) -> float:
        return 2.0 * math.pi * self.loops(per_second) * ((self.t / self.period) % 1.0)


@dataclass(frozen=True)
class Motion:
    kind: str                     # flow, flicker, sway, sheen
    direction: tuple = (0.0, 1.0)  # a flow's, in the image (x right, y down)
    rate: float = 0.3             # a flow's features per second; a warp's loops per second
    amount: float = 0.3           # a warp's size in features; a sheen's share of the light


FAMILY_MOTION = {
    "water": Motion("flow", (0.3, 1.0), 0.35),
    "fire": Motion("flicker", rate=0.6, amount=0.35),
    "sky_space": Motion("flow", (1.0, 0.15), 0.12),
    "weather": Motion("flow", (1.0, 0.1), 0.1),
    "plants": Motion("sway", rate=0.25, amount=0.12),
}
DEFAULT_MOTION = Motion("sheen", rate=0.25, amount=0.18)  # solids: light passing over them
PATTERN_MOTION = {
    "falls": Motion("flow", (0.0, 1.0), 1.2),
    "snowflakes": Motion("flow", (0.15, 1.0), 0.5),
    "caustics": Motion("flicker", rate=0.5, amount=0.25),
    "underwater": Motion("flicker", rate=0.3, amount=0.2),
    "reaction": Motion("sway", rate=0.2, amount=0.08),   # coral, lichen: a slow stir
    "embers": Motion("flicker", rate=0.4, amount=0.12),
    "candle": Motion("flicker", rate=0.8, amount=0.2),
}
MATERIAL_MOTION = {
    "bubbles": Motion("flow", (0.05, -1.0), 0.4),
    "raindrops": Motion("flow", (0.0, 1.0), 0.3),
    "frost": DEFAULT_MOTION, "snow": DEFAULT_MOTION, "mud": DEFAULT_MOTION, "sand": DEFAULT_MOTION,
}


def motion_of(material) -> Motion:
    return MATERIAL_MOTION.get(material.name) or PATTERN_MOTION.get(material.pattern) or \
        FAMILY_MOTION.get(material.family, DEFAULT_MOTION)


def _unit(d):
    n = math.hypot(*d) or 1.0
    return d[0] / n, d[1] / n


def samples(material, u, v, features: float, seed: int, clock: Clock | None) -> list:
    """[(u, v, weight)]: where the pattern is drawn at the clock's time (weights sum to 1; one at t = 0).
    features: the pattern's features per longer side (its scale), so motions are in features."""
    if clock is None or clock.still():
        return [(u, v, 1.0)]
    m = motion_of(material)
    if m.kind == "flow":
        dx, dy = _unit(m.direction)
        phase = (clock.t / clock.period) % 1.0
        # one loop of the two copies carries each by `span` features; whole features' worth per period
        span = max(1.0, round(m.rate * clock.speed * clock.period)) / max(features, 1e-6)
        out = []
        for shift in (0.0, 0.5):
            a = (phase + shift) % 1.0          # this copy's place in its loop; it jumps back where its weight is 0
            weight = 1.0 - abs(2.0 * a - 1.0)  # 0 at the jump, 1 half a loop from it
            if weight > 0.0:
                d = (a - 0.5) * span
                out.append((u - dx * d, v - dy * d, weight))
        total = sum(w for _, _, w in out)
        return [(a, b, w / total) for a, b, w in out]
    if m.kind in ("flicker", "sway"):
        angle = clock.angle(m.rate)
        k = features * 0.7  # the warp's noise a little coarser than the pattern's features
        x, y = u * k, v * k
        radius = 0.6  # noise units the warp's field turns through per loop: a frame's step stays small
        ox, oy = radius * (math.cos(angle) - 1.0), radius * math.sin(angle)
        size = m.amount / max(features, 1e-6)
        du = noise.fbm(x + ox + 3.1, y + oy, seed + 301, 3) - noise.fbm(x + 3.1, y, seed + 301, 3)
        dv = noise.fbm(x + ox, y + oy + 7.7, seed + 302, 3) - noise.fbm(x, y + 7.7, seed + 302, 3)
        if m.kind == "flicker":  # flames and light lick upwards more than sideways
            dv = dv - 0.5 * du.abs()
        return [(u + size * du, v + size * dv, 1.0)]
    return [(u, v, 1.0)]


def density_offset(material, clock: Clock | None) -> float:
    """What grows grows over the loop and recedes (plants): a density offset, 0 at t = 0."""
    if clock is None or clock.still() or motion_of(material).kind != "sway":
        return 0.0
    return 0.12 * (1.0 - math.cos(clock.angle(1.0 / max(clock.period, 1e-6)))) / 2.0


def light(material, u, v, seed: int, clock: Clock | None):
    """The light a sheen passes over a solid material (a multiplier about 1; None: none)."""
    if clock is None or clock.still():
        return None
    m = motion_of(material)
    if m.kind not in ("sheen", "flicker"):
        return None
    angle = clock.angle(m.rate if m.kind == "sheen" else m.rate * 0.5)
    ox, oy = 1.5 * (math.cos(angle) - 1.0), 1.5 * math.sin(angle)
    broad = noise.fbm(u * 2.5 + ox, v * 2.5 + oy, seed + 303, 3) - noise.fbm(u * 2.5, v * 2.5, seed + 303, 3)
    share = m.amount if m.kind == "sheen" else 0.12  # a fire breathes too
    return 1.0 + share * broad
