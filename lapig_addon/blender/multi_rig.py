"""Adding a projector to a rig that has one: a copy of the first's settings, placed where it does not light.

The pose comes from lapig_core/multi/placement (the first projector mirrored across the camera's view);
the rig records the new object through scene_state.
"""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from ...lapig_core.multi.placement import added_projector
from . import rig, scene_state

# the lapig_projector settings a new projector copies from the first: the same model, lens and light
COPIED_SETTINGS = ("resolution_x", "resolution_y", "throw_ratio", "shift_x", "shift_y", "brightness", "black_level",
                   "gamma", "transport_mode", "bounces", "indirect_samples", "indirect_downscale", "lens_radius_mm")


def copy_projector_settings(source, dest) -> None:
    """dest's lapig_projector settings set to source's (the light's tree rebuilt once, at the end)."""
    s, d = source.lapig_projector, dest.lapig_projector
    for name in COPIED_SETTINGS:
        setattr(d, name, getattr(s, name))
    dest.data.energy = source.data.energy


def add_projector(context):
    """A new projector like the rig's first, placed by the placement rule and focused on the object; returns
    (object, the sentence saying where it went). rig.RigError where the rig has no projector, camera or
    surface object yet."""
    scene = context.scene
    projectors = scene_state.rig_projectors(scene)
    _, camera, target = scene_state.rig_objects(scene)
    if not projectors or camera is None:
        raise rig.RigError("Add the projector and camera first (Add Projector and Camera)")
    if target is None:
        raise rig.RigError("Choose the surface object first")
    centre = rig.object_centre(target)
    placed = added_projector([np.array(p.matrix_world.translation) for p in projectors], centre,
                             np.array(camera.matrix_world.translation))
    new = rig.create_projector(scene, name=f"LAPIG Projector {len(projectors) + 1}")
    copy_projector_settings(projectors[0], new)  # each setting's update rebuilds the light's nodes
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = placed.rotation, placed.position
    new.matrix_world = Matrix(matrix.tolist())
    context.view_layer.update()
    new.lapig_projector.focus_distance = max(rig.axial_distance(new, centre), 0.01)
    rig.draw_cone_to(new, target)
    scene_state.add_extra_projector(scene, new)
    return new, placed.sentence(new.name, target.name)
