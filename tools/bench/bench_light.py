"""`python -m lapig_addon bench light --json`: light in real units, rendered with Cycles (issue 29).

1. lux_error_pct: a white Lambertian panel (albedo 0.8) lit by the projector light set from ANSI lumens
   through lapig_core.photometry.units.lumens_to_watts. Illuminance is measured from the render's
   linear pixel values (Raw view, exposure 0): E = 683 pi v / albedo. At normal incidence the mean of
   the nine ANSI points is compared with E = lumens / image area; at 45 degrees the centre is compared
   with the centre at normal incidence x cos 45 (the pinhole's centre is 1/m9 over the nine-point mean,
   see units.py). A Sun of 100 lux checks the measurement itself (its strength is W/m2 by definition).
2. contrast_ratio: the demo setup (the Sakura panel) at 100 lux of room light from every direction, for
   two presets (their lumens, contrast and the throw ratio nearest the demo's 1.5; the rig's placement
   and 800 x 600 frame stay): the median over the object of (E_white + E_room) / (E_white / C + E_room),
   both illuminances rendered, against the planning formula with E = lumens / image area at the panel.
3. dose_cap: the demo setup lit by the small LED preset, captured (24 pairs), trained (20 iterations) and
   a look generated; the object is marked 'high' (50 lux) in a 5 lux room. The free look's and the capped
   look's illuminance are rendered at the projector's native pixels (max on the region), and the frames
   are projected and captured on the rig for their PSNR against the free look's target. The cap holds
   each pixel's luminance; the stricter per-channel cap is measured beside it (channel_cap).
"""
from __future__ import annotations

import math
import os
import time

import bpy
import numpy as np

from ...lapig_core.common import metrics
from ...lapig_core.common.imageio import to_float, write_png
from ...lapig_core.common.resample import resize_image
from ...lapig_core.export.result_files import read_output_image
from ...lapig_core.optics.projector_model import quantised_frame
from ...lapig_core.photometry import dose, light_maps, presets, units
from ...lapig_addon.blender import demo_scene, light_render, rig, scene_state
from ...lapig_addon.blender.scene_store import scene_seams
from ...lapig_addon.cli import headless
from ...lapig_addon.services.light import light_report
from ...lapig_addon.services.generate.generate_job import GenerateJob
from ...lapig_addon.services.train.train_job import TrainModelsJob
from ...lapig_addon.services.capture.projection import project_and_capture

PANEL_LUMENS = 3000.0
PANEL_DISTANCE = 2.5
ALBEDO = 0.8
CONTRAST_PRESETS = ("optoma-ml500", "epson-eb-g5350")
DOSE_PRESET = "optoma-ml500"
DOSE_ROOM_LUX = 5.0
PROMPT = "Render it in the style of a Van Gogh oil painting"


def _white_panel(size=8.0):
    demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_plane_add(size=size, location=(0, 0, 0))
    panel = bpy.context.active_object
    material = bpy.data.materials.new("white Lambertian")
    tree = material.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (ALBEDO, ALBEDO, ALBEDO, 1.0)
    output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    panel.data.materials.append(material)
    return panel


def _patch(img, fx, fy, r=2):
    h, w = img.shape
    y, x = int(round(fy * h - 0.5)), int(round(fx * w - 0.5))
    return float(img[y - r:y + r + 1, x - r:x + r + 1].mean())


def _panel_check(out) -> dict:
    panel = _white_panel()
    scene = bpy.context.scene
    projector = rig.create_projector(scene)
    projector.location = (0.0, 0.0, PANEL_DISTANCE)  # looks down -Z at the panel, square to it
    model = scene_state.projector_model(projector)
    watts = units.lumens_to_watts(PANEL_LUMENS, model)
    projector.lapig_projector.brightness = watts  # its update sets the light's energy
    bpy.context.view_layer.update()
    area = units.image_area_m2(model, PANEL_DISTANCE)
    predicted = PANEL_LUMENS / area
    m9 = units.ansi_cos3_mean(model)
    results = {}
    for angle in (0.0, 45.0):
        panel.rotation_euler = (0.0, math.radians(angle), 0.0)
        bpy.context.view_layer.update()
        maps = light_render.projector_light_maps(scene, projector, panel, 240, 180)
        measured = units.lux_from_radiance(maps.white_radiance, ALBEDO)
        write_png(os.path.join(out, f"panel_{int(angle)}_lux.png"),
                  light_maps.lux_colour_map(measured, maps.on_object, 100, 3000))
        t = (1 / 6, 1 / 2, 5 / 6)
        nine = [_patch(measured, fx, fy) for fy in t for fx in t]
        nine_pass = [_patch(maps.white_lux, fx, fy) for fy in t for fx in t]
        results[angle] = {"nine_point_mean_lux": float(np.mean(nine)), "centre_lux": nine[4],
                          "nine_point_mean_lux_pass": float(np.mean(nine_pass)), "centre_lux_pass": nine_pass[4]}
    normal, tilted = results[0.0], results[45.0]
    centre_pred_45 = predicted / m9 * math.cos(math.radians(45))
    err_normal = 100 * (normal["nine_point_mean_lux"] / predicted - 1)
    err_45 = 100 * (tilted["centre_lux"] / centre_pred_45 - 1)
    cos_law = tilted["centre_lux"] / normal["centre_lux"]
    # the measurement itself: a Sun of 100 lux straight onto the panel, through the same pass
    panel.rotation_euler = (0, 0, 0)
    bpy.context.view_layer.update()
    sun = light_render.projector_light_maps(scene, projector, panel, 40, 30, ambient_lux=100.0,
                                            lamp_direction=(0, 0, -1))
    sun_lux = float(sun.ambient_lux[sun.on_object].mean())
    return {"lumens": PANEL_LUMENS, "light_power_w": round(watts, 3), "distance_m": PANEL_DISTANCE,
            "image_area_m2": round(area, 4), "predicted_lux": round(predicted, 2),
            "normal": {k: round(v, 2) for k, v in normal.items()}, "deg45": {k: round(v, 2) for k, v in tilted.items()},
            "predicted_centre_lux_45": round(centre_pred_45, 2),
            "lux_error_pct_normal": round(err_normal, 3), "lux_error_pct_45": round(err_45, 3),
            "cos_law_ratio": round(cos_law, 4), "cos_45": round(math.cos(math.radians(45)), 4),
            "flux_rule_light_power_w": round(units.lumens_to_watts(PANEL_LUMENS, model, rule="flux"), 3),
            "sun_100_lux_measured": round(sun_lux, 3),
            "lux_error_pct": round(max(abs(err_normal), abs(err_45)), 3)}


def _use_preset(projector, preset, throw_ratio=None) -> float:
    p = projector.lapig_projector
    if throw_ratio is not None:
        p.throw_ratio = preset.nearest_throw_ratio(throw_ratio)
    p.black_level = preset.black_level
    watts = units.lumens_to_watts(preset.ansi_lumens, scene_state.projector_model(projector))
    p.brightness = watts
    bpy.context.view_layer.update()
    return watts


def _contrast_check(out) -> dict:
    rows = {}
    for pid in CONTRAST_PRESETS:
        preset = presets.preset(pid)
        scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=out)
        _use_preset(projector, preset, throw_ratio=1.5)
        model = scene_state.projector_model(projector)
        maps = light_render.projector_light_maps(scene, projector, target, 160, 120, ambient_lux=100.0)
        on = maps.on_object
        c = units.contrast_ratio(maps.white_lux, maps.ambient_lux, preset.contrast)
        write_png(os.path.join(out, f"contrast_{pid}.png"), light_maps.contrast_colour_map(c, on))
        write_png(os.path.join(out, f"lux_{pid}.png"), light_maps.lux_colour_map(maps.white_lux, on))
        distance = rig.axial_distance(projector, rig.object_centre(target))
        planning = light_report.planning_contrast(preset.ansi_lumens, model, distance, 100.0, preset.contrast)
        plan = light_report.LightPlan(preset=pid, ambient_lux=100.0)
        report = light_report.light_report(plan, maps, None, model)
        rows[pid] = {"lumens": preset.ansi_lumens, "contrast_spec": preset.contrast,
                     "throw_ratio": round(model.throw_ratio, 3), "distance_m": round(distance, 3),
                     "measured_white_lux_median": round(float(np.median(maps.white_lux[on])), 1),
                     "planning_white_lux": round(units.planning_illuminance(
                         preset.ansi_lumens, units.image_area_m2(model, distance)), 1),
                     "measured_room_lux_median": round(float(np.median(maps.ambient_lux[on])), 2),
                     "measured": round(float(np.median(c[on])), 2), "planning_formula": round(planning, 2),
                     "error_pct": round(100 * (float(np.median(c[on])) / planning - 1), 2),
                     "below_5_share": report["contrast_below_5_share"], "warning": report["warning"],
                     "fixes": report["fixes"]}
    return rows


def _dose_cap(out, args) -> dict:
    preset = presets.preset(DOSE_PRESET)
    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=out)
    _use_preset(projector, preset, throw_ratio=1.5)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "dose.blend"))
    scene = bpy.context.scene
    projector, camera, target = scene_state.rig_objects(scene)
    t = time.perf_counter()
    settings = scene_state.capture_settings(scene, train_count=24, test_count=0, seed=args.seed)
    headless.run_capture(scene, settings)
    seams = scene_seams(scene)
    TrainModelsJob(seams, 20).run_to_completion()
    request = scene_state.generate_request(scene, prompt=PROMPT)
    generated = GenerateJob(seams, request, 20).run_to_completion()
    pipeline_s = time.perf_counter() - t
    bpy.ops.wm.save_mainfile()  # with its capture and look: `report --blend out/bench_light/dose.blend` runs on it
    folder = generated["folder"]
    model = scene_state.projector_model(projector)
    frame = to_float(quantised_frame(read_output_image(folder, "projector"), model.width, model.height, 8))
    limit = dose.ConservationLimit("high", schedule=dose.Schedule(8, 300))
    plan = light_report.LightPlan(preset=DOSE_PRESET, ambient_lux=DOSE_ROOM_LUX, limit=limit)
    room = light_render.projector_light_maps(scene, projector, target, 160, 120, ambient_lux=DOSE_ROOM_LUX)
    with light_render.LightStudio(scene, projector, target, model.width, model.height) as studio:
        native = studio.render_maps()
        ambient = resize_image(np.repeat(room.ambient_lux[..., None], 3, -1).astype(np.float32), model.width,
                               model.height)[..., 0]
        region = native.region & native.on_object
        capped, unmet = light_report.capped_frame(plan, frame, native.white_lux, ambient, region, model)
        # the stricter per-channel cap, for comparison (the product holds each pixel's luminance)
        cap, _ = dose.emitted_cap(native.white_lux, ambient, region, limit.limit_lux, model.black_level, 0.01)
        channel = dose.cap_input(frame, cap, model.gamma, model.black_level, 8).astype(np.float32)
        free_lux = studio.render_frame_lux(model.emitted(frame)) + ambient
        capped_lux = studio.render_frame_lux(model.emitted(capped)) + ambient
        channel_lux = studio.render_frame_lux(model.emitted(channel)) + ambient
    write_png(os.path.join(out, "dose_free_lux.png"), light_maps.lux_colour_map(free_lux, region, 1, 1000))
    write_png(os.path.join(out, "dose_capped_lux.png"), light_maps.lux_colour_map(capped_lux, region, 1, 1000))
    write_png(os.path.join(out, "dose_capped_frame.png"), capped)
    free_dose = dose.dose_figures(free_lux, region, limit)
    capped_dose = dose.dose_figures(capped_lux, region, limit)
    state = scene_state.read(scene)
    captured, _ = project_and_capture(seams.devices, state.capture_dir, [frame, capped, channel], chunk=3)
    target_img = resize_image(read_output_image(folder, "target"), captured.shape[2], captured.shape[1])
    psnr_free, psnr_capped, psnr_channel = (metrics.psnr(c, target_img) for c in captured)
    write_png(os.path.join(out, "dose_captures.png"), np.concatenate([target_img, captured[0], captured[1]], 1))
    return {"preset": DOSE_PRESET, "room_lux": DOSE_ROOM_LUX, "pipeline_s": round(pipeline_s, 1),
            "free": free_dose, "capped": capped_dose, "cap": unmet,
            "dose_cap": {"max_lux": capped_dose["max_lux"], "limit_lux": limit.limit_lux,
                         "psnr_cost_db": round(float(psnr_free - psnr_capped), 3)},
            "psnr_free_db": round(float(psnr_free), 3), "psnr_capped_db": round(float(psnr_capped), 3),
            "channel_cap": {"max_lux": round(float(channel_lux[region].max()), 2),
                            "psnr_cost_db": round(float(psnr_free - psnr_channel), 3)},
            "free_exceeds_limit": free_dose["max_lux"] > limit.limit_lux}


def run(args) -> dict:
    out = os.path.abspath(args.out or os.path.join("out", "bench_light"))
    os.makedirs(out, exist_ok=True)
    t = time.perf_counter()
    panel = _panel_check(out)
    contrast = _contrast_check(out)
    dose_case = _dose_cap(out, args)
    return {"benchmark": "light", "lux_error_pct": panel["lux_error_pct"], "lux_goal_pct": 5.0,
            "panel": panel, "contrast_ratio": contrast, "dose_cap": dose_case["dose_cap"],
            "dose_case": dose_case, "seconds": round(time.perf_counter() - t, 1), "out": out}
