# SPDX-License-Identifier: GPL-3.0-or-later
"""Health checks of a real rig before the long capture: each failure says what to change.

- exposure: the white frame does not clip where the projector lights the surface, and the black frame
  is not crushed to 0 there (the camera would not see the darkest patterns);
- a gray ramp, up then down: it must come back monotonic, and the same both ways; an auto exposure or
  auto gain that meters each picture answers the same gray differently after a bright frame than after a
  dark one (RoomAliveToolkit#2: auto gain blowing out the Gray codes);
- the rig's gamma, fitted to the ramp and recorded: the projector's own where the camera is linear (a
  raw or linear-profile camera), the projector's times the camera's tone curve otherwise.

The structured light's coverage and its decode are checked by the capture sequence itself, after the
Gray code (sequence._check_coverage, the registration's valid share).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

RAMP_LEVELS = (0.0, 0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.0)


@dataclass
class HealthReport:
    results: dict = field(default_factory=dict)  # check -> its figures
    problems: list = field(default_factory=list)  # plain sentences, what to change
    failed: list = field(default_factory=list)  # the checks the problems belong to: 'exposure', 'ramp'

    @property
    def ok(self) -> bool:
        return not self.problems

    def as_dict(self) -> dict:
        return {**self.results, "problems": list(self.problems), "failed": list(self.failed)}

    def fail(self, check: str, problem: str) -> None:
        self.problems.append(problem)
        if check not in self.failed:
            self.failed.append(check)


def _levels(image) -> np.ndarray:
    x = np.asarray(image)
    return x.astype(np.float32).mean(-1) / (255.0 if x.dtype == np.uint8 else 1.0)


def run_checks(shoot, size, ignore=None, clip_share=0.02, crushed_share=0.5,
               ramp_tolerance=0.04) -> HealthReport:
    """``shoot(frame) -> camera image`` (the rig's verified shot), ``size`` (width, height) of the
    projector; ``ignore``: camera pixels to leave out (where the sync's frame code shows, which changes
    from shot to shot)."""
    w, h = size
    report = HealthReport()

    def flat(level):
        return np.full((h, w, 3), int(round(level * 255)), np.uint8)

    black, white = _levels(shoot(flat(0.0))), _levels(shoot(flat(1.0)))
    lit = (white - black) > 0.08  # camera pixels the projector lights
    if ignore is not None:
        lit &= ~ignore
    lit_share = float(lit.mean())
    report.results["lit_share_of_camera"] = round(lit_share, 4)
    if lit_share < 0.01:
        report.fail("exposure", "the camera sees almost none of the projection: aim it at the lit surface, "
                               "or raise its exposure")
        return report
    clipped = float((white[lit] >= 0.985).mean())
    crushed = float((black[lit] <= 0.004).mean())
    report.results["exposure"] = {"white_clipped_share": round(clipped, 4), "black_crushed_share": round(crushed, 4)}
    if clipped > clip_share:
        report.fail("exposure", f"white clips on {clipped:.0%} of the lit surface: lower the camera's exposure "
                               "or gain (or the projector's brightness) and run the checks again")
    if crushed > crushed_share:
        report.fail("exposure", f"black reads 0 on {crushed:.0%} of the lit surface: raise the camera's "
                               "exposure a little, or darken the room")

    def ramp(levels):
        return np.array([float(_levels(shoot(flat(v)))[lit].mean()) for v in levels])

    up = ramp(RAMP_LEVELS)
    down = ramp(RAMP_LEVELS[::-1])[::-1]
    span = max(float(up[-1] - up[0]), 1e-6)
    steps = np.diff(up) / span
    drift = float(np.abs(up - down).max() / span)
    report.results["ramp"] = {"levels": list(RAMP_LEVELS), "up": [round(float(v), 4) for v in up],
                              "down": [round(float(v), 4) for v in down], "passes_differ_by": round(drift, 4)}
    if drift > ramp_tolerance:
        report.fail("ramp", f"the same grays read {drift:.0%} differently going up and coming down: the "
                               "camera's auto exposure or auto gain is on: lock its exposure, gain and white "
                               "balance, then run the checks again")
    elif (steps <= 0).any():
        report.fail("ramp", "a brighter gray came back darker: the camera's picture is not steady "
                               "(auto exposure, flicker or a moving camera): lock its settings and run the "
                               "checks again")
    report.results["ramp_gamma"] = _fit_gamma(np.array(RAMP_LEVELS), (up + down) / 2)
    return report


def _fit_gamma(levels: np.ndarray, response: np.ndarray) -> float | None:
    """Gamma of (response - black) / (white - black) = level ** gamma, on the ramp's inner levels."""
    lo, hi = response[0], response[-1]
    rel = (response - lo) / max(hi - lo, 1e-6)
    keep = (levels > 0) & (levels < 1) & (rel > 0.01) & (rel < 0.99)
    if keep.sum() < 2:
        return None
    return round(float(np.polyfit(np.log(levels[keep]), np.log(rel[keep]), 1)[0]), 3)
