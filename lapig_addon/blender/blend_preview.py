"""The Blend preview of a rig of several projectors (issue 36): each projector's light shows its share of the
object in its own colour (1 red, 2 green, 3 blue, 4 yellow), from the capture's blend weights
(lapig_core/multi/blend.share_frames), so the viewport in Rendered mode and a Cycles render show where each
projector reaches and how the overlaps hand over."""
from __future__ import annotations

from ...lapig_core.multi.blend import blend_weights, share_frames
from ...lapig_core.multi.first_look import load_joint_model
from . import projector_nodes, result_preview, scene_state
from .scene_state import projector_model

COLOUR_NAMES = ("red", "green", "blue", "yellow")


def show_blend_preview(scene) -> str:
    """Set every projector's light to its share frame; returns the report line. RuntimeError (one line)
    without a capture of this rig of several projectors with its first look."""
    state = scene_state.read(scene)
    names = state.rig.projectors
    if len(names) < 2:
        raise RuntimeError("the Blend preview needs a rig of several projectors")
    model = load_joint_model(state.capture_dir) if state.capture_dir else None
    if model is None or model.count != len(names) or state.capture_fingerprint != state.rig.fingerprint:
        raise RuntimeError("capture the rig of several projectors first: the Blend preview shows its blend weights")
    frames = share_frames(model.maps, blend_weights(model.maps), model.alpha_gammas)
    projectors = scene_state.rig_projectors(scene)
    for k, (projector, frame) in enumerate(zip(projectors, frames)):
        light = projector_model(projector).emitted(frame)
        image = result_preview.frame_image(result_preview.IMAGE_PREFIX + f"blend share {k + 1}", light)
        projector_nodes.set_projected_image(projector.data, image)
    shares = ", ".join(f"{n} {COLOUR_NAMES[k % 4]}" for k, n in enumerate(names))
    return f"Blend preview: each projector lights its share in its colour ({shares})"
