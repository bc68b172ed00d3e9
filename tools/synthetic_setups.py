"""Varied projector-camera setups rendered by our own capture code, for pretraining and benchmarks.

A setup is a surface object (shape, procedural texture, albedo tint), a rig pose (the placed rig
orbited around the object) and a room (ambient light). PRETRAIN_SETUPS and BENCH_SETUPS share no
texture instance, tint, pose or ambient: the benchmark measures setups the pretraining never saw,
and the Sakura texture appears only in the benchmark.
"""
from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass

import bpy
import numpy as np
from mathutils import Matrix

from ..lapig_addon.blender import scene_state
from ..lapig_addon.cli import headless


@dataclass(frozen=True)
class SetupSpec:
    name: str
    shape: str = "panel"
    surface: str = "wood"
    seed: int = 0
    tint: tuple = (1.0, 1.0, 1.0)
    ambient: float = 0.03
    orbit_deg: float = 0.0  # rig turned about the object's vertical axis
    tilt_deg: float = 0.0  # rig raised (+) or lowered (-) about the object
    brightness: float = 1.0  # projector power relative to the default
    finish: str = "matte"  # demo_scene.FINISHES: matte, glazed (gloss), marble (subsurface)
    transport: str = "FAST"  # light transport of its captures: FAST (direct, pinhole) or REALISTIC
    lens_radius_mm: float = 5.0  # the projector's aperture in REALISTIC mode, focused on the object

    def to_dict(self) -> dict:
        return asdict(self)


PRETRAIN_SETUPS = (
    SetupSpec("p01_wood_panel", "panel", "wood", 1),
    SetupSpec("p02_stripe_panel_orbit", "panel", "stripe", 2, orbit_deg=12, ambient=0.05),
    SetupSpec("p03_clouds_dark_panel", "panel", "clouds", 3, tint=(0.35, 0.35, 0.4), ambient=0.01),
    SetupSpec("p04_spray_box", "box", "spray", 4, ambient=0.06, orbit_deg=-10),
    SetupSpec("p05_bench_statue", "statue", "bench", 5, ambient=0.02, tilt_deg=8),
    SetupSpec("p06_wood_blue_box", "box", "wood", 6, tint=(0.45, 0.6, 1.0), orbit_deg=15),
    SetupSpec("p07_bright_clouds_statue", "statue", "clouds", 7, tint=(1.3, 1.3, 1.25), ambient=0.08),
    SetupSpec("p08_stripe_green_panel", "panel", "stripe", 8, tint=(0.6, 1.0, 0.55), tilt_deg=-6),
    SetupSpec("p09_spray_panel_dim", "panel", "spray", 9, brightness=0.6, ambient=0.04),
    SetupSpec("p10_bench_panel_tilt", "panel", "bench", 10, tilt_deg=10, orbit_deg=-8),
    SetupSpec("p11_stripe_statue_red", "statue", "stripe", 11, tint=(1.0, 0.55, 0.5), orbit_deg=-15),
    SetupSpec("p12_clouds_box_dark", "box", "clouds", 12, tint=(0.25, 0.25, 0.25), ambient=0.0),
    # Realistic transport (issue 16): bounce light, defocus, gloss and subsurface, on shapes and finishes
    # of REALISTIC_SETUPS but with other textures, seeds, tints and poses (the benchmark stays unseen).
    SetupSpec("p13_stripe_corner_real", "corner", "stripe", 13, tint=(0.8, 0.9, 1.0), ambient=0.04,
              orbit_deg=-6, transport="REALISTIC"),
    SetupSpec("p14_bench_bowl_real", "bowl", "bench", 14, ambient=0.03, tilt_deg=5, transport="REALISTIC"),
    SetupSpec("p15_wood_glazed_vase", "vase", "wood", 15, ambient=0.02, orbit_deg=10, finish="glazed",
              transport="REALISTIC"),
    SetupSpec("p16_spray_relief_defocus", "relief", "spray", 16, ambient=0.03, orbit_deg=-30,
              lens_radius_mm=15.0, transport="REALISTIC"),
    SetupSpec("p17_clouds_panel_dark_real", "panel", "clouds", 17, tint=(0.5, 0.45, 0.4), ambient=0.02,
              orbit_deg=5, lens_radius_mm=10.0, transport="REALISTIC"),
    SetupSpec("p18_wood_marble_statue", "statue", "wood", 18, tint=(1.2, 1.2, 1.15), ambient=0.03, orbit_deg=12,
              finish="marble", transport="REALISTIC"),
)

BENCH_SETUPS = (
    SetupSpec("b1_sakura_panel", "panel", "sakura", 101, ambient=0.03, orbit_deg=6),
    SetupSpec("b2_spray_statue_warm", "statue", "spray", 102, tint=(1.0, 0.85, 0.7), ambient=0.05, orbit_deg=10),
    SetupSpec("b3_bench_box_dim", "box", "bench", 103, tint=(0.8, 0.8, 0.8), ambient=0.02, tilt_deg=5,
              orbit_deg=-12),
)

# Realistic light transport (bounces, projector defocus, vignetting, gloss, subsurface), for
# `bench transport`: shapes, finishes and texture seeds that no pretraining setup has.
REALISTIC_SETUPS = (
    SetupSpec("r1_wood_corner", "corner", "wood", 201, tint=(0.95, 0.9, 0.85), ambient=0.03, orbit_deg=8,
              transport="REALISTIC"),
    SetupSpec("r2_clouds_niche", "bowl", "clouds", 202, tint=(1.2, 1.15, 1.1), ambient=0.02, transport="REALISTIC"),
    SetupSpec("r3_glazed_vase", "vase", "spray", 203, ambient=0.03, tilt_deg=6, finish="glazed",
              transport="REALISTIC"),
    SetupSpec("r4_marble_bust", "statue", "clouds", 204, tint=(1.35, 1.35, 1.3), ambient=0.03, orbit_deg=-8,
              finish="marble", transport="REALISTIC"),
    SetupSpec("r5_tilted_relief", "relief", "stripe", 205, ambient=0.02, orbit_deg=35, lens_radius_mm=20.0,
              transport="REALISTIC"),
)

ALL_SETUPS = {s.name: s for s in PRETRAIN_SETUPS + BENCH_SETUPS + REALISTIC_SETUPS}


def orbit_rig(projector, camera, centre, orbit_deg: float, tilt_deg: float):
    """Turn the placed projector and camera together about the object's centre."""
    if not orbit_deg and not tilt_deg:
        return
    c = Matrix.Translation(centre)
    yaw = Matrix.Rotation(math.radians(orbit_deg), 4, "Z")
    # tilt about the horizontal axis perpendicular to the view direction
    view = (projector.matrix_world.translation - centre).normalized()
    axis = view.cross((0.0, 0.0, 1.0))
    pitch = Matrix.Rotation(math.radians(-tilt_deg), 4, axis) if axis.length > 1e-6 else Matrix()
    transform = c @ yaw @ pitch @ c.inverted()
    for ob in (projector, camera):
        ob.matrix_world = transform @ ob.matrix_world
    bpy.context.view_layer.update()


def build_setup(spec: SetupSpec, folder: str):
    """A fresh scene for the spec: (scene, projector, camera, target)."""
    from ..lapig_core.optics.transport import LightTransport

    scene, projector, camera, target = headless.build_demo_setup(spec.shape, spec.surface, folder, spec.seed,
                                                                 tint=spec.tint, finish=spec.finish)
    projector.lapig_projector.brightness *= spec.brightness
    bpy.context.view_layer.update()
    centre = target.matrix_world @ _bounds_centre(target)
    orbit_rig(projector, camera, centre, spec.orbit_deg, spec.tilt_deg)  # about the centre: the focus holds
    p, c = projector.lapig_projector, camera.lapig_camera
    scene_state.write_light_transport(projector, camera, LightTransport(
        mode=spec.transport, projector_focus_m=p.focus_distance, projector_lens_radius_mm=spec.lens_radius_mm,
        camera_focus_m=c.focus_distance))
    return scene, projector, camera, target


def _bounds_centre(obj):
    from mathutils import Vector

    corners = np.array([tuple(c) for c in obj.bound_box])
    return Vector(((corners.min(0) + corners.max(0)) / 2).tolist())


def layout(data_root, name: str):
    """Where a synthetic setup lives: a data set root of its own, `data_root/<name>` (the public
    layout shares projector images between the setups of a root, and each setup has its own)."""
    from ..lapig_core.capture.dataset import DatasetLayout

    return DatasetLayout(os.path.join(data_root, name), name)


def load_setup(data_root, name: str):
    from ..lapig_core.capture.dataset import load_capture_set

    return load_capture_set(layout(data_root, name).setup_dir)


def get_spec(name: str) -> SetupSpec:
    try:
        return ALL_SETUPS[name]
    except KeyError:
        raise ValueError(f"unknown setup '{name}'; known: {', '.join(ALL_SETUPS)}") from None

def render_synthetic_setups(specs, out, train, test, seed=0, skip_existing=True, sheet=None) -> dict:
    """Capture each synthetic setup into `out/<name>`, a data set root of its own; returns figures.

    Own roots because the public layout shares the projector images of a root between its setups,
    and every setup here projects its own seeded patterns.
    """
    import time

    from ..lapig_core.capture import dataset as ds
    from ..lapig_core.common.imageio import write_png

    out = os.path.abspath(out)
    textures = headless.ensure_dir(os.path.join(out, "textures"))
    summary = {}
    for spec in specs:
        setup_layout = layout(out, spec.name)
        if skip_existing and setup_layout.setup_json.exists():
            print(f"{spec.name}: already captured", flush=True)
            continue
        t = time.perf_counter()
        scene, projector, camera, target = build_setup(spec, textures)
        settings = scene_state.capture_settings(scene, out_dir=str(setup_layout.root), setup_name=spec.name,
                                                train_count=train, test_count=test, ambient=spec.ambient,
                                                seed=seed + spec.seed)
        result = headless.run_capture(scene, settings)
        meta = result["meta"]
        meta["synthetic_setup"] = spec.to_dict()
        ds.write_setup_json(setup_layout, meta)
        if sheet is not None:
            write_png(os.path.join(out, f"{spec.name}_sheet.png"), sheet(result["setup_dir"]))
        summary[spec.name] = {"working_valid_fraction": round(meta["working_valid_fraction"], 3),
                              "seconds": round(time.perf_counter() - t, 1)}
        print(f"{spec.name}: {summary[spec.name]}", flush=True)
    return summary
