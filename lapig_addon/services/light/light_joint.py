"""Light in real units for the joint strategy (Rig.strategy JOINT, issue 36): the maps are over the rig camera's
pixels, where the light of every projector adds. No bpy.

blender/light_plan_run.JointSceneLight renders each projector's light through the camera (the room's once, with
the first); JointReportWay is the Light Report's way for it (services/light/light_report_job.LightReportJob), and the
dose cap's (services/light/dose_cap_joint) takes one factor on every projector's light from joint_cap_factor. One
projector keeps its own frame (services/light/light_report_job.ProjectorReportWay): its report and the per-pixel cap
are in the projector's pixels, where the paper's figures and the recorded reports come from.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ....lapig_core.photometry import units
from .light_report import LightPlan, light_report


def joint_lumens(plan: LightPlan, watts: "list[float]", models: list) -> list[float]:
    """Each projector's lumens on a rig of several: the plan's (its model's, or the lumens given) are the first
    projector's, as for one; every other projector's are in proportion to its own light power as its settings
    give it (units.watts_to_lumens of its Blender watts at its own lens), so a copy of the first (Add Projector)
    has the first's lumens, and a projector set twice as bright has twice as many."""
    first = units.watts_to_lumens(watts[0], models[0])
    return [plan.resolved_lumens * units.watts_to_lumens(w, m) / first for w, m in zip(watts, models)]


def joint_report(plan: LightPlan, maps: list, emitted: "list[np.ndarray] | None", models: list, names,
                 lumens: "list[float]") -> tuple[dict, object, "np.ndarray | None"]:
    """The light report of several projectors over the same samples (the camera's pixels): each one's maps
    (its white_lux at its own `lumens`), each one's look (`emitted[k]`: its relative emitted light at the maps'
    samples; None: every projector white). Light adds: the report is light_report's on the summed maps, with the
    look's emitted light as the lux-weighted mean of theirs (so white x emitted is the sum of their looks' lux),
    the lumens and the light power the rig's total, the dose on the summed light; 'projectors' names each
    one's lumens and share of the light on the object. Returns (report, summed maps, combined emitted)."""
    from ....lapig_core.photometry.light_passes import projector_shares, sum_projector_maps

    total = sum_projector_maps(maps)
    looks = [m.white_lux * (1.0 if emitted is None else np.asarray(e, np.float64))
             for m, e in zip(maps, emitted or [None] * len(maps))]
    combined = None
    if emitted is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            combined = np.where(total.white_lux > 1e-12, sum(looks) / total.white_lux, 0.0)
    rig_plan = replace(plan, preset="", lumens=float(sum(lumens)), contrast=plan.resolved_contrast or 0.0)
    report = light_report(rig_plan, total, combined, models[0])
    report["light_power_w"] = round(sum(units.lumens_to_watts(lm, m) for lm, m in zip(lumens, models)), 3)
    report["preset"] = plan.projector_preset.to_dict() if plan.preset else None
    valid = np.asarray(total.on_object, bool)
    shares = projector_shares(looks, valid)
    white_shares = projector_shares([m.white_lux for m in maps], valid)
    report["projectors"] = [
        {"name": n, "lumens": round(float(lm), 1), "light_power_w": round(units.lumens_to_watts(lm, m), 3),
         "share": round(s, 4), "white_share": round(w, 4),
         "white_lux_mean": round(float(mp.white_lux[valid].mean()), 2) if valid.any() else None}
        for n, lm, m, s, w, mp in zip(names, lumens, models, shares, white_shares, maps)]
    report["projectors_line"] = "; ".join(f"{p['name']} {p['share']:.0%} of the light ({p['lumens']:,.0f} lm)"
                                          for p in report["projectors"])
    return report, total, combined


def joint_cap_factor(plan: LightPlan, total, combined, margin: float = 0.01) -> float:
    """The one factor on every projector's emitted light that keeps the sum of their looks plus the room within
    the plan's limit on the marked region (maps and look as joint_report returns them; `margin` below it, as
    one projector's cap keeps): 1 when the look is within it already, 0 when the room alone is over it. Light
    adds, so scaling all of them alike scales the sum and keeps their blend."""
    if plan.limit is None:
        raise ValueError("set a conservation category first: there is no limit to keep")
    region = np.asarray(total.region, bool) & np.asarray(total.on_object, bool)
    look = (total.white_lux * (1.0 if combined is None else combined))[region]
    room = np.broadcast_to(total.ambient_lux, region.shape)[region]
    limit = plan.limit.limit_lux * (1 - margin)
    with np.errstate(divide="ignore", invalid="ignore"):
        room_left = np.where(look > 1e-9, (limit - room) / look, np.inf)
    return float(np.clip(room_left, 0.0, 1.0).min()) if room_left.size else 1.0


def scaled_frame(frame: np.ndarray, model, scale: float, bit_depth: int = 16) -> np.ndarray:
    """A projector frame whose emitted light is `scale` times the frame's (each channel, so the hue and the
    blend with the other projectors hold; never below the black level), back to input values rounded down to
    the bit depth's steps, never above the frame's own."""
    frame = np.asarray(frame, np.float64)
    black, gamma = model.black_level, model.gamma
    e = black + (1.0 - black) * np.power(np.clip(frame, 0, 1), gamma)
    rel = np.clip((np.maximum(e * scale, black) - black) / max(1.0 - black, 1e-12), 0.0, 1.0)
    steps = 2 ** bit_depth - 1
    return np.minimum(np.floor(np.power(rel, 1.0 / gamma) * steps + 1e-9) / steps, frame).astype(np.float32)


def result_frames(folder) -> "list[np.ndarray]":
    """Every projector's image of a joint result (result.json's projectors[k].image), as the light emits it."""
    from ....lapig_core.multi.result_files import projector_images

    return [image for _, image in projector_images(folder)]


class JointReportWay:
    """LightReportJob's way for the joint strategy (see light_report_job.ProjectorReportWay): every projector's
    light over the camera's pixels (JointSceneLight.steps: one render a step), added on a worker. 'projectors'
    name each one's lumens and share of the light on the object; 'dose' is that of their sum, and
    'dose_cap_scale' the one factor on every projector's light that Limit Look to the Dose would apply."""

    @staticmethod
    def own_result(folder):
        """The result whose look is reported: a joint result only (a result of one projector has no image for
        every projector of the rig: a white frame each then)."""
        from ....lapig_core.multi.result_files import is_multi_result

        return folder if folder and is_multi_result(folder) else None

    @staticmethod
    def render_steps(light, folder, start, end):
        return (yield from light.steps(result_frames(folder) if folder else None, start, end))

    @staticmethod
    def report(plan, light, rendered, folder, room=None):
        maps, emitted = rendered
        report, total, combined = joint_report(plan, maps, emitted, light.models, light.names, light.lumens)
        if not total.on_object.any():
            raise ValueError(f"no projector reaches '{light.target_name}' in the camera's view: aim them at it")
        report["frame"] = "camera"  # the maps are over the rig camera's pixels
        report["result"] = folder
        report["dose_cap_scale"] = round(joint_cap_factor(plan, total, combined), 4) if plan.limit else None
        report["projector_table_rows"] = [{**row, "target_lux": p["white_lux_mean"]}
                                          for row, p in zip(light.rows, report["projectors"])]
        return report, total, combined

    @staticmethod
    def discard(rendered):
        """Nothing to remove: the joint light reads its passes as it renders."""
