"""Operators of the show (issue 38): the list of looks (add, remove, move), Bake Show (the previz on the timeline),
Export Show and Play Show. Thin: the scene is read and written through blender/scene_state and
blender/show_timeline, the work is services/show/show_jobs and rigs/live_output's jobs."""
import os

import bpy

from ..lapig_addon.blender import scene_state, show_timeline
from ..lapig_addon.blender.modal_runner import JobRunnerMixin
from ..lapig_addon.blender.operator_boundary import ReportsErrors, report_notes
from ..lapig_addon.rigs import live_output


class LAPIG_OT_show_add_look(ReportsErrors, bpy.types.Operator):
    """Add a look to the end of the show: the scene's current result, or the result folder given"""
    bl_idname = "lapig.show_add_look"
    bl_label = "Add Look"
    bl_options = {"REGISTER", "UNDO"}

    directory: bpy.props.StringProperty(name="Result folder", subtype="DIR_PATH",
                                        description="A result folder (empty: the scene's current result)")

    def execute(self, context):
        scene = context.scene
        folder = bpy.path.abspath(self.directory) if self.directory else scene_state.read(scene).result_dir
        if not folder:
            raise ValueError("Generate a look first: the show is a list of results")
        if not os.path.isfile(os.path.join(folder, "result.json")):
            raise ValueError(f"{folder} is not a result folder (no result.json)")
        index = scene_state.add_show_look(scene, folder)
        self.report({"INFO"}, f"Look {index + 1} added to the show")
        return {"FINISHED"}


class LAPIG_OT_show_remove_look(ReportsErrors, bpy.types.Operator):
    """Take the active look off the show"""
    bl_idname = "lapig.show_remove_look"
    bl_label = "Remove Look"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        if not scene_state.remove_show_look(context.scene, scene_state.show_index(context.scene)):
            self.report({"WARNING"}, "The show has no look to remove")
            return {"CANCELLED"}
        return {"FINISHED"}


class LAPIG_OT_show_move_look(ReportsErrors, bpy.types.Operator):
    """Move the active look one place earlier or later in the show"""
    bl_idname = "lapig.show_move_look"
    bl_label = "Move Look"
    bl_options = {"REGISTER", "UNDO"}

    direction: bpy.props.EnumProperty(items=[("UP", "Up", ""), ("DOWN", "Down", "")])

    def execute(self, context):
        scene = context.scene
        scene_state.move_show_look(scene, scene_state.show_index(scene), -1 if self.direction == "UP" else 1)
        return {"FINISHED"}


class LAPIG_OT_bake_show(JobRunnerMixin, bpy.types.Operator):
    """Make every frame of the show for each projector (PNGs in the .blend's data folder) and put them on the
    projector lights: scrubbing the timeline shows them on the object, and rendering the animation renders the
    previz, with no add-on needed (a render farm can render it)"""
    bl_idname = "lapig.bake_show"
    bl_label = "Bake Show"

    def make_job(self, context):
        return show_timeline.bake_job(context.scene)

    def on_done(self, context, job):
        show_timeline.baked(context.scene, job.result)
        show_timeline.rewrite_markers(context.scene)
        self.report({"INFO"}, f"Baked {job.result['frames']} frames into {job.result['folder']}")


class LAPIG_OT_export_show(JobRunnerMixin, bpy.types.Operator):
    """Export the show per projector as a video (or a PNG sequence) with a JSON sidecar of its looks, times,
    transitions, motions and frame rate"""
    bl_idname = "lapig.export_show"
    bl_label = "Export Show"

    def make_job(self, context):
        s = context.scene.lapig
        return show_timeline.export_job(context.scene, bpy.path.abspath(s.show_export_dir), s.show_codec)

    def on_done(self, context, job):
        report_notes(self, job.result.get("notes", []))
        files = ", ".join(output["path"] for output in job.result["outputs"])
        self.report({"INFO"}, f"Exported {job.result['frames']} frames: {files}")


class LAPIG_OT_play_show(JobRunnerMixin, bpy.types.Operator):
    """Play the show on the projector window at the scene's frame rate, its frames made ahead (Esc stops)"""
    bl_idname = "lapig.play_show"
    bl_label = "Play Show"

    @classmethod
    def waits_for(cls, context):
        return "" if live_output.open_sinks() else "Show on Projector first: the show plays in the projector window"

    def make_job(self, context):
        sinks = live_output.open_sinks()
        if not sinks:
            raise ValueError("Show on Projector first: the show plays in the projector window")
        return show_timeline.play_job(context.scene, sinks[-1])

    def on_done(self, context, job):
        played = job.result
        if played is None:
            return
        late = f", {played['late_frames']} late ({played['late_frame_pct']:g} %)" if played["late_frames"] else ""
        self.report({"INFO"}, f"Played {played['frames']} frames in {played['seconds']:.2f} s{late}")


CLASSES = (LAPIG_OT_show_add_look, LAPIG_OT_show_remove_look, LAPIG_OT_show_move_look, LAPIG_OT_bake_show,
           LAPIG_OT_export_show, LAPIG_OT_play_show)

register, unregister = bpy.utils.register_classes_factory(CLASSES)
