"""Blender's result sink: the projector light emits the generated frame, and the object shows the
preview mode the scene was in (services/ports.ResultSink)."""
from __future__ import annotations

from ..services.ports import ProjectorFrame
from . import projector_nodes, result_preview, scene_state
from .scene_state import projector_model


class ProjectorLightSink:
    several_projectors = True  # each projector's light takes its own frame

    def __init__(self, scene):
        self.scene = scene

    def show(self, frame: ProjectorFrame) -> None:
        k = frame.projector_index
        if k == 0:  # the rig's projector, as ever
            projector = scene_state.rig_objects(self.scene)[0]
        else:
            projectors = scene_state.rig_projectors(self.scene)
            projector = projectors[k] if k < len(projectors) else None
        if projector is None:
            return
        # the light of the frame's pixels: the same quantised pixels Export writes
        light = projector_model(projector).emitted(frame.pixels)
        suffix = f" {frame.projector_index + 1}" if frame.projector_index else ""
        image = result_preview.frame_image(result_preview.IMAGE_PREFIX + "projector image" + suffix, light)
        projector_nodes.set_projected_image(projector.data, image)
        mode = scene_state.read(self.scene).preview_mode
        if mode != "ORIGINAL":
            result_preview.apply_mode(self.scene, mode)

