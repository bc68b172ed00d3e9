"""The light plan and its report: lumens, lux, luminance, contrast and the light dose, as plain values.

No bpy: the maps come from blender/light_render (Cycles from the projector's viewpoint) or a test's
fakes; this module turns them and the result's projector frame into the report that the `report`
command prints, the result folder keeps (light_report.json, beside its colour maps) and Export copies
into the sidecar. services/light/light_report_job runs it as a job: these functions are its worker's part.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np

from ....lapig_core.common.atomic import commit
from ....lapig_core.common.imageio import encode_png, to_float
from ....lapig_core.common.jsonable import json_default_or_str
from ....lapig_core.common.resample import resize_image
from ....lapig_core.export.result_files import read_output_image
from ....lapig_core.optics.projector_model import quantised_frame
from ....lapig_core.photometry import dose, light_maps, presets, units

REPORT_FILE = "light_report.json"
LUX_MAP, CONTRAST_MAP, LUMINANCE_MAP = "light_lux", "light_contrast", "light_luminance"  # PNGs beside it


@dataclass(frozen=True)
class LightPlan:
    preset: str = ""  # a projector preset id ('' : none)
    lumens: float = 0.0  # ANSI lumens; 0: the preset's
    contrast: float = 0.0  # the projector's contrast ratio; 0: the preset's (none: the model's black level)
    ambient_lux: float = 0.0  # the room's illuminance on the object
    lamp_direction: tuple | None = None  # the way the room's lamp shines (None: from every direction)
    limit: dose.ConservationLimit | None = None  # None: no conservation guard
    region_material: str = ""  # the marked region: a material of the object ('' : the whole object)
    region_group: str = ""  # or a vertex group of it (faces whose vertices all weigh 0.5 or more)

    def problem(self) -> str:
        """Why the plan cannot be reported ('' when it can): every input checked before any render."""
        try:
            if self.preset:
                presets.preset(self.preset)
            elif not self.lumens:
                return "give the projector's brightness in lumens, or choose a projector preset"
            if self.lumens:
                units.check_lumens(self.lumens)
            if self.contrast and self.contrast <= 1:
                return f"a contrast ratio must be more than 1:1, got {self.contrast:g}"
            units.check_lux(self.ambient_lux)
        except units.LightUnitError as exc:
            return str(exc)
        if self.lamp_direction is not None:
            d = np.asarray(self.lamp_direction, float)
            if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) < 1e-9:
                return "the lamp's direction must be three numbers, not all 0"
        if self.region_material and self.region_group:
            return "mark the region by a material or by a vertex group, not both"
        return self.limit.problem() if self.limit is not None else ""

    def check(self) -> "LightPlan":
        problem = self.problem()
        if problem:
            raise ValueError(problem)
        return self

    @property
    def projector_preset(self):
        return presets.preset(self.preset) if self.preset else None

    @property
    def resolved_lumens(self) -> float:
        return float(self.lumens or self.projector_preset.ansi_lumens)

    @property
    def resolved_contrast(self) -> float | None:
        if self.contrast:
            return float(self.contrast)
        return float(self.projector_preset.contrast) if self.preset else None


def emitted_luma(model, frame_pixels: np.ndarray) -> np.ndarray:
    """The frame's relative emitted light, as a luminance share of white (H, W)."""
    return model.emitted(frame_pixels) @ units.LUMA


def light_report(plan: LightPlan, maps, emitted: np.ndarray | None, model) -> dict:
    """The report of a look (emitted: its relative emitted light per map pixel; None: a white frame).

    maps: white_lux, ambient_lux, albedo, on_object, region (H, W) as blender/light_render makes them,
    rendered with the light's power set from plan's lumens."""
    plan.check()
    contrast = plan.resolved_contrast
    emitted = np.ones_like(maps.white_lux) if emitted is None else np.asarray(emitted, np.float64)
    summary = light_maps.light_summary(maps.white_lux, maps.ambient_lux, maps.albedo, emitted, maps.on_object,
                                       plan.resolved_lumens, contrast)
    report = {"lumens": plan.resolved_lumens,
              "light_power_w": round(units.lumens_to_watts(plan.resolved_lumens, model), 3),
              "conversion": "W = 4 pi lumens / (683 A1 m9): ANSI nine-point rule (lapig_core/photometry/units.py)",
              "ambient_lux": plan.ambient_lux, "lamp_direction": plan.lamp_direction,
              "preset": plan.projector_preset.to_dict() if plan.preset else None, **summary}
    if plan.limit is not None:
        region = np.asarray(maps.region, bool) & np.asarray(maps.on_object, bool)
        total = maps.white_lux * emitted + maps.ambient_lux
        look = (maps.white_lux * emitted)[region]
        room = np.broadcast_to(maps.ambient_lux, region.shape)[region]
        with np.errstate(divide="ignore", invalid="ignore"):
            room_left = np.where(look > 1e-9, (plan.limit.limit_lux - room) / look, np.inf)
        scale = float(np.clip(room_left, 0.0, None).min()) if room_left.size else float("inf")
        report["dose"] = {**dose.dose_figures(total, region, plan.limit),
                          # the lumens at which this look's brightest point on the region meets the limit
                          "lumens_within_limit": (round(plan.resolved_lumens * scale) if scale < 1 else None),
                          "region": (f"material '{plan.region_material}'" if plan.region_material else
                                     f"vertex group '{plan.region_group}'" if plan.region_group else
                                     "the whole object")}
    return report


def plan_maps(passes, scale: float, target_name: str, plan: LightPlan, check: bool = True):
    """The maps of a light studio's passes (passes.maps(): read and computed here, on the caller's thread) with
    the white frame's light scaled from the light's power to the plan's lumens (`scale`, light adds linearly);
    check: refused where the projector misses the object or lights none of the marked region."""
    maps = passes.maps()
    maps.white_lux = maps.white_lux * scale
    if not check:
        return maps
    if not maps.on_object.any():
        raise ValueError(f"the projector does not reach '{target_name}': aim it at the object")
    marked = (f"the material '{plan.region_material}'" if plan.region_material else
              f"the vertex group '{plan.region_group}'" if plan.region_group else "")
    if marked and not (maps.region & maps.on_object).any():
        raise ValueError(f"{marked} has no faces the projector lights: mark faces it reaches, or the whole object")
    return maps


def look_emitted(folder, model, width: int, height: int) -> np.ndarray:
    """The result's relative emitted light (luminance share of white) at the maps' width x height."""
    small = resize_image(model.emitted(native_frame(folder, model)).astype(np.float32), width, height)
    return small @ units.LUMA


def report_images(plan: LightPlan, maps, emitted: np.ndarray | None) -> dict:
    """The report's colour maps (name -> RGB image): the lux on the object, the contrast against the room, the
    luminance."""
    total = maps.white_lux * (emitted if emitted is not None else 1.0) + maps.ambient_lux
    contrast = light_maps.finite_contrast(units.contrast_ratio(maps.white_lux, maps.ambient_lux,
                                                               plan.resolved_contrast))
    return {LUX_MAP: light_maps.lux_colour_map(total, maps.on_object),
            CONTRAST_MAP: light_maps.contrast_colour_map(contrast, maps.on_object),
            LUMINANCE_MAP: light_maps.lux_colour_map(units.luminance_cd_m2(maps.albedo, total), maps.on_object,
                                                     0.3, 3000)}


def native_frame(folder, model) -> np.ndarray:
    """A result's projector frame as the projector receives it (native, 8-bit steps, float)."""
    return to_float(quantised_frame(read_output_image(folder, "projector"), model.width, model.height, 8))


def capped_frame(plan: LightPlan, frame: np.ndarray, white_lux: np.ndarray, ambient_lux, region, model,
                 bit_depth: int = 8, margin: float = 0.01) -> tuple[np.ndarray, dict]:
    """The projector frame (float, native H x W x 3) limited so the marked region stays within the
    plan's lux limit; maps at the frame's size. Returns the frame and what the cap could not do."""
    plan.check()
    if plan.limit is None:
        raise ValueError("set a conservation category first: there is no limit to keep")
    cap, unmet = dose.emitted_cap(white_lux, ambient_lux, region, plan.limit.limit_lux,
                                  black_level=model.black_level, margin=margin)
    # the cap holds each pixel's luminance (what the lux meter reads): the least change to the look
    capped = dose.cap_input_luminance(frame, cap, model.gamma, model.black_level, bit_depth)
    changed = float((np.abs(capped - np.asarray(frame, np.float64)) > 1e-9).any(-1).mean())
    notes = []
    if unmet["room_light_over_limit_share"] > 0:
        notes.append(f"the room's light alone is over {plan.limit.limit_lux:g} lux on "
                     f"{unmet['room_light_over_limit_share']:.0%} of the region: dim the room, no projector image can help")
    elif unmet["projector_black_over_limit_share"] > 0:
        notes.append(f"the projector's black level with the room's light is over the limit on "
                     f"{unmet['projector_black_over_limit_share']:.0%} of the region: dim the room or use fewer lumens")
    return capped.astype(np.float32), {**unmet, "limit_lux": plan.limit.limit_lux, "margin": margin,
                                       "changed_pixel_share": round(changed, 4), "notes": notes}


def write_report(folder, report: dict, images: dict | None = None) -> str:
    """light_report.json in the result folder, with its colour maps (name -> image, as PNGs): each file written
    whole, all of them or none (common/atomic.commit), the report last. Its path."""
    path = os.path.join(os.fspath(folder), REPORT_FILE)
    data = json.dumps(report, indent=2, default=json_default_or_str, allow_nan=False).encode("utf-8")
    commit(_pngs(folder, images or {}) + [(path, data)])
    return path


def write_maps(folder, images: dict) -> None:
    """The colour maps as PNGs in a folder of their own (the `report` command's --maps), all or none."""
    os.makedirs(os.fspath(folder), exist_ok=True)
    commit(_pngs(folder, images))


def _pngs(folder, images: dict) -> list:
    return [(os.path.join(os.fspath(folder), name + ".png"), encode_png(image, 8, name)) for name, image in
            images.items()]


def read_report(folder) -> dict | None:
    """The result folder's light report, or None when it has none (or an unreadable one)."""
    path = os.path.join(os.fspath(folder), REPORT_FILE)
    try:
        with open(path, encoding="utf-8") as handle:
            return json.load(handle)
    except (OSError, ValueError):
        return None


def planning_contrast(lumens: float, model, distance_m: float, ambient_lux: float,
                      projector_contrast: float | None = None) -> float:
    """The planner's contrast on a surface square to the axis at distance_m: E = lumens / area."""
    white = units.planning_illuminance(lumens, units.image_area_m2(model, distance_m))
    return float(units.contrast_ratio(white, ambient_lux, projector_contrast))


def projector_settings(plan: LightPlan, model) -> tuple[dict, list[str]]:
    """The projector settings of the plan's model (a preset: its native resolution, the throw ratio and
    lens shift nearest the rig's within its ranges; always: the light's power and the black level), and a
    note for each setting the model cannot keep as the rig has it."""
    plan.check()
    p = plan.projector_preset
    notes = []
    settings = {}
    throw, shift_x, shift_y = model.throw_ratio, model.shift_x, model.shift_y
    if p is not None:
        settings["resolution_x"], settings["resolution_y"] = p.native_resolution
        throw = p.nearest_throw_ratio(model.throw_ratio)
        if abs(throw - model.throw_ratio) > 1e-6:
            notes.append(f"the {p.name} throws {p.throw_ratio[0]:g} to {p.throw_ratio[1]:g}, not "
                         f"{model.throw_ratio:g}: set to {throw:g} (move the projector to keep the image's size)")
        shift_x = min(max(model.shift_x, p.lens_shift_x[0]), p.lens_shift_x[1])
        shift_y = min(max(model.shift_y, p.lens_shift_y[0]), p.lens_shift_y[1])
        if (shift_x, shift_y) != (model.shift_x, model.shift_y):
            notes.append(f"the {p.name}'s lens shift reaches x {p.lens_shift_x[0]:g} to {p.lens_shift_x[1]:g} and "
                         f"y {p.lens_shift_y[0]:g} to {p.lens_shift_y[1]:g}: set to {shift_x:g}, {shift_y:g}")
        if tuple(p.native_resolution) != (model.width, model.height):
            notes.append(f"native resolution {p.native_resolution[0]} x {p.native_resolution[1]}: the capture "
                         "and the looks must be made again")
    settings.update(throw_ratio=throw, shift_x=shift_x, shift_y=shift_y)
    shaped = type(model)(**{**model.to_dict(), **{"width": settings.get("resolution_x", model.width),
                                                   "height": settings.get("resolution_y", model.height),
                                                   "throw_ratio": throw, "shift_x": shift_x, "shift_y": shift_y}})
    settings["brightness"] = units.lumens_to_watts(plan.resolved_lumens, shaped)
    if plan.resolved_contrast:
        settings["black_level"] = units.black_level_from_contrast(plan.resolved_contrast)
    return settings, notes
