# SPDX-License-Identifier: GPL-3.0-or-later
"""`python -m lapig_addon bench looks --json [--unseen]`: do everyday prompts get a look of their own, or a tint?

The suite is tools/bench/looks_suite.toml: everyday prompts (materials, plants, water, fire, sky, weather, made
things, animals), each with the checks written down for it before anything was rendered. Every prompt's target
is made by the offline backend (styletransfer: the prompt plan, the looks and the 26 styles), without PSA, on the
demo wall (the sakura panel of `run_demo.sh`, white-lit: its albedo at 0.92 of the projector's white over a black
level of 0.02), at 320 x 240.

  tint_share: the share of prompts whose target has no structure of its own. Structure: the standard deviation of
      the residual after a per-channel least-squares affine fit of the target to the captured surface (its RGB and
      a constant), high-passed (minus its Gaussian blur, sigma 12 px) at 240 px height. A tint of the surface
      measures about 0.01, a texture of its own 0.07 to 0.12; below TINT_BELOW (0.05) counts as a tint.
  checks_pass_share: the share of prompts whose every check passes (hues, darkness, greyness, scale).
  same_look_pairs: pairs of different prompts whose targets differ by a mean absolute difference below 0.05.
  look_seconds_800x600: the median seconds of one look made from its parameters at 800 x 600 (render_at on the
      white-lit surface at that size), over the prompts.
Sheet: out/bench_looks/sheet.png (every prompt's target, its structure and its checks).

slider_to_preview_seconds: one slider moved (Scale) -> the look's new preview image at 800 x 600, as the Stylize
panel's sliders make it (services/generate/look_edit.remake: the look drawn again from its record, no prompt model, no PSA,
then compensated by the first look's classical model at that size), on a capture of the device check's rig
(the device check's fake rig captured with an 800 x 600 projector, 8 pairs); slider_to_preview_changed says the image
did change (mean absolute difference).

--psa: also `psa_gain_db` per family: on the device check's capture (tools/bench/fixtures/device_check, the fake
rig's, 128 x 96) with the pretrained networks and the per-pixel model's choice, as the app's first Generate,
every prompt stylized without PSA and with it (the app's settings, the iteration cap at 20), and the gain of the
simulated capture's PSNR against its own target; beside them the same for NEURAL_MIXES (the 26-style network's
looks). Sheet: out/bench_looks/psa_sheet.png (target and simulated capture, without and with PSA).
"""
from __future__ import annotations

import colorsys
import itertools
import os
import platform
import statistics
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SUITE = Path(__file__).resolve().parent / "looks_suite.toml"
SIZE = (320, 240)  # width, height: the structure is measured at 240 px height
TINT_BELOW = 0.05
SAME_LOOK_BELOW = 0.05
HIGH_PASS_SIGMA = 12.0
COLOURED_SATURATION, COLOURED_AT_LEAST = 0.15, 0.2
SCALES = {"fine": (0.0, 14.0), "medium": (8.0, 48.0), "coarse": (24.0, float("inf"))}  # wavelength in px
NEURAL_MIXES = ("starry_blue_yellow:1", "rust_woodgrain:1", "teal_red_mosaic:1")
PSA_ITERATIONS = 20


@dataclass(frozen=True)
class Case:
    text: str
    family: str
    hues: tuple = ()
    share: float = 0.0
    lum: tuple | None = None
    sat: tuple | None = None
    scale: str | None = None
    unseen: bool = False


def load_suite(path: Path = SUITE, unseen: bool = False) -> list[Case]:
    with open(path, "rb") as f:
        rows = tomllib.load(f)["prompt"]
    cases = []
    for row in rows:
        known = {"text", "family", "hues", "share", "lum", "sat", "scale", "unseen"}
        extra = set(row) - known
        if extra:
            raise ValueError(f"{path.name}: '{row.get('text')}' has unknown keys {sorted(extra)}")
        if row.get("scale") not in (None, *SCALES):
            raise ValueError(f"{path.name}: '{row['text']}' has scale {row['scale']!r}: use {', '.join(SCALES)}")
        cases.append(Case(row["text"], row["family"], tuple(tuple(h) for h in row.get("hues", ())),
                          float(row.get("share", 0.0)), tuple(row["lum"]) if "lum" in row else None,
                          tuple(row["sat"]) if "sat" in row else None, row.get("scale"), bool(row.get("unseen"))))
    return [c for c in cases if unseen or not c.unseen]


def demo_wall(size=SIZE) -> np.ndarray:
    """The demo's panel texture (sakura, seed 0) as the camera sees it lit white, at size (w, h), float RGB."""
    import cv2

    from ...lapig_core.common.surfaces import make_surface

    w, h = size
    albedo = make_surface("sakura", size=max(w, h), seed=0)
    top = (albedo.shape[0] - h * albedo.shape[1] // w) // 2  # the panel's 4:3 middle
    albedo = albedo[top: top + h * albedo.shape[1] // w]
    albedo = cv2.resize(albedo.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    return np.clip(0.02 + 0.92 * albedo, 0, 1).astype(np.float32)


# ------------------------------------------------------------------------------------------------ measures

def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    import cv2

    return cv2.GaussianBlur(img, (0, 0), sigmaX=sigma, sigmaY=sigma, borderType=cv2.BORDER_REFLECT)


def at_height(img: np.ndarray, height: int = SIZE[1]) -> np.ndarray:
    import cv2

    if img.shape[0] == height:
        return img.astype(np.float32)
    width = round(img.shape[1] * height / img.shape[0])
    return cv2.resize(img.astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)


def structure(target: np.ndarray, surface: np.ndarray) -> float:
    """The issue's measure: std of the high-passed residual of a per-channel affine fit of target to surface."""
    target, surface = at_height(target), at_height(surface)
    a = np.concatenate([surface.reshape(-1, 3), np.ones((surface.shape[0] * surface.shape[1], 1), np.float32)], 1)
    t = target.reshape(-1, 3)
    coef, *_ = np.linalg.lstsq(a.astype(np.float64), t.astype(np.float64), rcond=None)
    residual = (t - a @ coef).reshape(target.shape).astype(np.float32)
    return float((residual - _blur(residual, HIGH_PASS_SIGMA)).std())


def luminance(img: np.ndarray) -> np.ndarray:
    return img @ np.array([0.299, 0.587, 0.114], np.float32)


def hsv(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(hue in degrees, HSV saturation) per pixel."""
    mx, mn = img.max(-1), img.min(-1)
    sat = np.where(mx > 1e-6, (mx - mn) / np.maximum(mx, 1e-6), 0.0)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    d = np.maximum(mx - mn, 1e-6)
    hue = np.where(mx == r, ((g - b) / d) % 6, np.where(mx == g, (b - r) / d + 2, (r - g) / d + 4)) * 60.0
    return hue % 360.0, sat


def wavelength(img: np.ndarray) -> float:
    """The wavelength (px) below which half of the luminance's spectral energy lies (DC left out)."""
    lum = luminance(at_height(img))
    lum = lum - lum.mean()
    power = np.abs(np.fft.rfft2(lum)) ** 2
    fy = np.fft.fftfreq(lum.shape[0])[:, None]
    fx = np.fft.rfftfreq(lum.shape[1])[None, :]
    radius = np.sqrt(fx ** 2 + fy ** 2)
    power[radius == 0] = 0
    weights = power.copy()
    weights[:, 1:-1] *= 2  # rfft's half plane: the columns but the first and last stand for two
    order = np.argsort(radius, axis=None)
    cumulative = np.cumsum(weights.flat[order])
    if cumulative[-1] <= 0:
        return float("inf")
    median_f = radius.flat[order][np.searchsorted(cumulative, cumulative[-1] / 2)]
    return float(1.0 / max(median_f, 1e-6))


def in_ranges(hue: np.ndarray, ranges) -> np.ndarray:
    inside = np.zeros(hue.shape, bool)
    for lo, hi in ranges:
        inside |= (hue >= lo) & (hue <= hi)
    return inside


def checks(case: Case, target: np.ndarray) -> dict:
    """{check: {"value", "want", "pass"}} for the checks the suite wrote down for this prompt."""
    img = at_height(target)
    out = {}
    hue, sat = hsv(img)
    if case.hues:
        coloured = sat >= COLOURED_SATURATION
        share_coloured = float(coloured.mean())
        share = float(in_ranges(hue[coloured], case.hues).mean()) if coloured.any() else 0.0
        out["hues"] = {"value": round(share, 3), "coloured": round(share_coloured, 3),
                       "want": f">= {case.share} in {list(map(list, case.hues))}",
                       "pass": share_coloured >= COLOURED_AT_LEAST and share >= case.share}
    if case.lum:
        v = float(luminance(img).mean())
        out["lum"] = {"value": round(v, 3), "want": list(case.lum), "pass": case.lum[0] <= v <= case.lum[1]}
    if case.sat:
        v = float(sat.mean())
        out["sat"] = {"value": round(v, 3), "want": list(case.sat), "pass": case.sat[0] <= v <= case.sat[1]}
    if case.scale:
        v = wavelength(img)
        lo, hi = SCALES[case.scale]
        out["scale"] = {"value": round(v, 1), "want": case.scale, "pass": lo <= v <= hi}
    return out


def same_look_pairs(texts: list[str], targets: list[np.ndarray]) -> list[tuple[str, str, float]]:
    pairs = []
    for (i, a), (j, b) in itertools.combinations(enumerate(targets), 2):
        if texts[i] != texts[j]:
            mad = float(np.abs(at_height(a) - at_height(b)).mean())
            if mad < SAME_LOOK_BELOW:
                pairs.append((texts[i], texts[j], round(mad, 4)))
    return pairs


# ------------------------------------------------------------------------------------------------ the run

@dataclass
class Rendered:
    case: Case
    target: np.ndarray
    described: str
    structure: float = 0.0
    checks: dict = field(default_factory=dict)
    seconds_800x600: float = 0.0
    unmatched: list = field(default_factory=list)


def describe_line(info: dict) -> str:
    """What the backend made of the prompt, in its own words (the panel's result line)."""
    return str(info.get("understood_line") or info.get("styles") or "?")


def render_case(backend, case: Case, surface: np.ndarray, surface_800: "torch.Tensor | None") -> Rendered:
    import torch

    from ...lapig_core.lgst.not_understood import PromptNotUnderstood

    x = torch.from_numpy(surface).permute(2, 0, 1)[None].float()
    try:
        target = backend.stylize(x, case.text, seed=0)[0].permute(1, 2, 0).clamp(0, 1).numpy()
    except PromptNotUnderstood as exc:  # refused with its line: no look, so no structure of its own (counted)
        done = Rendered(case, surface.copy(), f"refused: {exc}", unmatched=[str(exc)])
        done.structure = structure(done.target, surface)
        done.checks = checks(case, done.target)
        return done
    info = backend.describe()
    done = Rendered(case, target, describe_line(info),
                    unmatched=[n for n in info.get("notes", []) if "matched no" in n or "weak match" in n])
    if surface_800 is not None:
        t = time.perf_counter()
        backend.render_at(surface_800)
        done.seconds_800x600 = time.perf_counter() - t
    done.structure = structure(target, surface)
    done.checks = checks(case, target)
    return done


def sheet(rendered: list[Rendered], path: str) -> str:
    from ...lapig_core.common.imageio import write_png
    from ...lapig_core.common.sheets import labelled_grid

    labels = []
    for r in rendered:
        failed = [k for k, v in r.checks.items() if not v["pass"]]
        mark = "TINT " if r.structure < TINT_BELOW else ""
        labels.append(f"{r.case.text[:34]} | {mark}s={r.structure:.3f}" + (f" x {','.join(failed)}" if failed else ""))
    grid = labelled_grid([r.target for r in rendered], labels, columns=8, cell=220,
                         title="bench looks: every prompt's target without PSA (TINT: structure < 0.05; x: failed checks)")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    write_png(path, grid)
    return path


def psa_gains(cases: list[Case], out: str) -> dict:
    """Simulated PSNR without and with PSA per prompt, their gain per family, and the neural mixes' beside them."""
    from ...lapig_core.capture.dataset import load_capture_set
    from ...lapig_core.common import metrics
    from ...lapig_core.common.imageio import write_png
    from ...lapig_core.common.sheets import labelled_grid
    from ...lapig_core.photometric import choice as compensator_choice
    from ...lapig_core.photometric.classical import ClassicalModel
    from ...lapig_core.photometric.finetune import start_model
    from ...lapig_core.pipeline import SavedModels, as_image, stylize, surface_models
    from ...lapig_core.psa.adaptation import PSASettings
    from .device_fixture import FIXTURE

    cs = load_capture_set(str(FIXTURE))
    classical = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    comp, sim = start_model("CompenNeSt", "compensation"), start_model("PCNet", "simulation")
    chosen, _ = compensator_choice.fit_and_choose(cs, comp, sim, classical)  # handed over: nothing saved
    models = surface_models(cs, saved=SavedModels(comp, sim, chosen, classical))
    settings = PSASettings(seed=0, max_iterations=PSA_ITERATIONS)

    def one(prompt, mix=None):
        res = stylize(cs, models, prompt, mix=mix, settings=settings, seed=0)
        without = metrics.psnr(as_image(res.without.simulated), as_image(res.without.target))
        adapted = metrics.psnr(as_image(res.with_psa.simulated), as_image(res.with_psa.target))
        return without, adapted, res

    from ...lapig_core.lgst.not_understood import PromptNotUnderstood

    rows, tiles, labels = [], [], []
    for case in cases:
        try:
            without, adapted, res = one(case.text)
        except PromptNotUnderstood as exc:  # refused in one line (counted by the suite's figures): no PSA to run
            rows.append({"prompt": case.text, "family": case.family, "refused": str(exc)})
            continue
        rows.append({"prompt": case.text, "family": case.family, "without_db": round(without, 3),
                     "with_psa_db": round(adapted, 3), "gain_db": round(adapted - without, 3),
                     "retention": res.style_retention()})
        if len(tiles) < 64:
            tiles += [as_image(res.without.target), as_image(res.without.simulated), as_image(res.with_psa.target),
                      as_image(res.with_psa.simulated)]
            labels += [case.text[:22], f"sim {without:.1f} dB", "with PSA", f"sim {adapted:.1f} dB"]
    neural = []
    for mix in NEURAL_MIXES:
        without, adapted, _ = one("", mix=mix)
        neural.append({"mix": mix, "without_db": round(without, 3), "with_psa_db": round(adapted, 3),
                       "gain_db": round(adapted - without, 3)})
    families = {}
    for row in rows:
        if "gain_db" in row:
            families.setdefault(row["family"], []).append(row["gain_db"])
    write_png(os.path.join(out, "psa_sheet.png"), labelled_grid(tiles, labels, columns=8, cell=180,
              title="bench looks --psa: target and simulated capture, without and with PSA (device check capture)"))
    return {"psa_gain_db": {f: round(statistics.mean(g), 3) for f, g in sorted(families.items())},
            "psa_gain_db_all": round(statistics.mean(r["gain_db"] for r in rows if "gain_db" in r), 3),
            "psa_refused": [r["prompt"] for r in rows if "refused" in r],
            "psa_gain_db_neural": round(statistics.mean(r["gain_db"] for r in neural), 3),
            "psa_rows": rows, "psa_neural": neural, "psa_capture": str(FIXTURE),
            "psa_iterations_cap": PSA_ITERATIONS}


SLIDER_PROMPT = "old cobblestones"
SLIDER_SIZE = (800, 600)


def slider_to_preview(out: str) -> dict:
    """One slider change -> the new preview image at 800 x 600 (module docstring), timed; bpy-free."""
    import tempfile

    from ...lapig_addon.services.generate.look_edit import remake
    from ...lapig_core.capture.dataset import load_capture_set
    from ...lapig_core.look_parameters import LookParameters
    from ...lapig_core.photometric.classical import ClassicalModel
    from ...lapig_core.pipeline import first_look_models, stylize
    from .device_fixture import make_fixture

    with tempfile.TemporaryDirectory() as folder:  # the capture, and a result folder without look_state.npz
        setup = make_fixture(Path(folder) / "capture", train=8, test=0, projector=SLIDER_SIZE, camera=(400, 300))
        cs = load_capture_set(str(setup))
        models = first_look_models(cs, ClassicalModel.fit(cs.prj_train, cs.cam_train))
        res = stylize(cs, models, SLIDER_PROMPT, psa=False, seed=0)
        summary = {"prompt": SLIDER_PROMPT, "backend": "styletransfer", "seed": 0, "lgst": res.describe}
        start = LookParameters.from_dict(res.describe["look_parameters"])
        before = remake(summary, folder, cs, models, start, SLIDER_SIZE)
        t = time.perf_counter()
        after = remake(summary, folder, cs, models, start.edited({"scale": 1.6}), SLIDER_SIZE)
        seconds = time.perf_counter() - t
    a, b = before["images"]["projector_native"], after["images"]["projector_native"]
    return {"slider_to_preview_seconds": round(seconds, 3), "slider_to_preview_size": list(SLIDER_SIZE),
            "slider_to_preview_prompt": SLIDER_PROMPT, "slider_to_preview_shape": list(a.shape),
            "slider_to_preview_changed": round(float(np.abs(after["images"]["target_native"]
                                                            - before["images"]["target_native"]).mean()), 4),
            "slider_to_preview_projector_changed": round(float(np.abs(a - b).mean()), 4)}


def run(args) -> dict:
    import torch

    from ...lapig_core.lgst import get_backend
    t0 = time.perf_counter()
    cases = load_suite(unseen=bool(getattr(args, "unseen", False)))
    only = getattr(args, "prompts_like", None)
    if only:
        cases = [c for c in cases if only.lower() in c.text.lower()]
    surface = demo_wall()
    surface_800 = torch.from_numpy(demo_wall((800, 600))).permute(2, 0, 1)[None].float()
    backend = get_backend("styletransfer")
    rendered = []
    for case in cases:
        rendered.append(render_case(backend, case, surface, surface_800))
    wall_structure = structure(surface, surface)  # the surface itself: 0 by construction (the fit is exact)
    tints = [r.case.text for r in rendered if r.structure < TINT_BELOW]
    passed = [r for r in rendered if all(v["pass"] for v in r.checks.values())]
    pairs = same_look_pairs([r.case.text for r in rendered], [r.target for r in rendered])
    families = {}
    for r in rendered:
        f = families.setdefault(r.case.family, {"prompts": 0, "tints": 0, "checks_pass": 0})
        f["prompts"] += 1
        f["tints"] += r.structure < TINT_BELOW
        f["checks_pass"] += all(v["pass"] for v in r.checks.values())
    out = os.path.abspath(getattr(args, "out", None) or "out/bench_looks")
    psa = psa_gains(cases, out) if getattr(args, "psa", False) else {}
    slider = slider_to_preview(out)
    held_back = [r for r in rendered if r.case.unseen]
    unseen = {} if not held_back else {
        "unseen_prompts": len(held_back),
        "unseen_tint_share": round(sum(r.structure < TINT_BELOW for r in held_back) / len(held_back), 3),
        "unseen_checks_pass_share": round(sum(all(v["pass"] for v in r.checks.values()) for r in held_back)
                                          / len(held_back), 3)}
    per_prompt = [{"prompt": r.case.text, "family": r.case.family, "look": r.described, "unseen": r.case.unseen,
                   "structure": round(r.structure, 4), "checks": r.checks, "unmatched": r.unmatched}
                  for r in rendered]
    return {"benchmark": "looks", "prompts": len(rendered), "unseen_included": bool(getattr(args, "unseen", False)),
            "tint_share": round(len(tints) / max(1, len(rendered)), 3), "tints": tints,
            "structure_median": round(statistics.median(r.structure for r in rendered), 4) if rendered else None,
            "checks_pass_share": round(len(passed) / max(1, len(rendered)), 3),
            "checks_failed": [r.case.text for r in rendered if r not in passed],
            "same_look_pairs": len(pairs), "same_look_examples": pairs[:10],
            "look_seconds_800x600": round(statistics.median(r.seconds_800x600 for r in rendered), 3)
            if rendered else None,
            "families": families, "per_prompt": per_prompt, "wall_self_structure": round(wall_structure, 4),
            "sheet": sheet(rendered, os.path.join(out, "sheet.png")),
            **unseen, **psa, **slider, "bench_total_s": round(time.perf_counter() - t0, 1),
            "machine": platform.processor() or platform.machine()}
