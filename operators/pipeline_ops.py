"""Operators of the artist's path after the capture: train, generate, render, preview, export."""
import importlib
import os

import bpy

from ..lapig_addon.blender import live_devices, prompt_preview, result_preview, scene_state
from ..lapig_addon.blender.modal_runner import BackgroundJobRunner, JobRunnerMixin, cancel_background
from ..lapig_addon.blender.operator_boundary import (AsksForFolder, ReportsErrors, poll_reason, refuse, report_notes,
                                                     show_in_image_editor)
from ..lapig_addon.blender.properties import PREVIEW_MODES
from ..lapig_addon.blender.scene_store import BlenderSceneStore, scene_seams
from ..lapig_addon.services.panel import panel_state
from ..lapig_core.common.deps import require


class NeedsTorch:
    """Mix into the operators that run the networks: without torch Blender greys their buttons out and the
    tooltip says what to install (Capture, the preview and the exports need no torch)."""

    @classmethod
    def poll(cls, context):
        return poll_reason(cls, panel_state.torch_blocker())


def _jobs(name: str):
    """A torch-backed job's module (train.train_job, generate.look_edit, ... relative to services), imported once
    a button needs it: the add-on enables without torch."""
    require("torch")
    return importlib.import_module(f"..lapig_addon.services.{name}", __package__)


def _train_job(scene):
    job = _jobs("train.train_job").TrainModelsJob(scene_seams(scene), scene_state.finetune_iterations(scene))
    job.check()  # fail now, with the reason, not on the thread (several projectors: nothing to train)
    return job


class LAPIG_OT_train_models(NeedsTorch, JobRunnerMixin, bpy.types.Operator):
    """Fine-tune the networks on this capture (about two minutes), then render both compensations, keep the better"""
    bl_idname = "lapig.train_models"
    bl_label = "Train Models"
    replaces_models = True  # a Train in the background is cancelled first

    def make_job(self, context):
        return _train_job(context.scene)

    def on_done(self, context, job):
        self.report({"INFO"}, scene_state.read(context.scene).models_status)


class LAPIG_OT_train_background(BackgroundJobRunner, bpy.types.Operator):
    """Train the models in the background while you work (started after a Capture)"""
    bl_idname = "lapig.train_background"
    bl_label = "Train in the Background"
    bl_options = {"INTERNAL"}

    def make_job(self, context):
        scene = context.scene
        if panel_state.train_blocker(scene_state.read(scene)):  # no torch, no capture: the first look stays
            return None
        job = _train_job(scene)
        job.rig_in_use = lambda: live_devices.rig_in_use(job.seams.store.scene)  # their live window stays theirs
        job.device_per_render = True  # no studio scene left between two steps, while the artist works
        self.scene_name = scene.name
        return job

    def refresh(self, context, job):
        # an undo may have replaced the scene the job was made with: the seams of the scene of that name
        scene = bpy.data.scenes.get(self.scene_name)
        if scene is not None:
            job.seams = scene_seams(scene)

    def on_done(self, context, job):
        self.report({"INFO"}, "Trained in the background: " + scene_state.read(context.scene).models_status)


class LAPIG_OT_cancel_background_train(ReportsErrors, bpy.types.Operator):
    """Stop the training in the background; the first look stays in use"""
    bl_idname = "lapig.cancel_background_train"
    bl_label = "Cancel"

    def execute(self, context):
        if cancel_background():
            self.report({"WARNING"}, "Training in the background cancelled: the scene is as it was")
        return {"FINISHED"}


class LAPIG_OT_generate(NeedsTorch, JobRunnerMixin, bpy.types.Operator):
    """Turn the prompt into a look for this surface and compute the projector image that shows it"""
    bl_idname = "lapig.generate"
    bl_label = "Generate"

    def make_job(self, context):
        prompt_preview.stop()  # the fast path's preview must not land on the full PSA run's result
        scene = context.scene
        job = _jobs("generate.generate_job").GenerateJob(scene_seams(scene), scene_state.generate_request(scene),
                                                scene_state.finetune_iterations(scene))
        job.check()  # validates prompt and capture on the main thread, with a clear message
        return job

    def on_done(self, context, job):
        if job.result:
            report_notes(self, _jobs("generate.generate_job").result_notes(job.result["summary"]))
            self.report({"INFO"}, "Generated: " + job.result["summary_line"])


class LAPIG_OT_edit_look(NeedsTorch, JobRunnerMixin, bpy.types.Operator):
    """Draw the world look again with the sliders' values and compensate it (no new prompt, no Train)"""
    bl_idname = "lapig.edit_look"
    bl_label = "Update Look"
    reset: bpy.props.BoolProperty(name="Reset", default=False, options={"SKIP_SAVE"},
                                  description="Back to the values the prompt gave")

    def make_job(self, context):
        scene = context.scene
        changes = {} if self.reset else scene_state.look_slider_values(scene)
        job = _jobs("generate.look_edit").EditLookJob(scene_seams(scene), changes, reset=self.reset)
        job.check()  # a bad value or a look without sliders: one line, before any work
        return job

    def on_done(self, context, job):
        if job.result:
            self.report({"INFO"}, "Look: " + job.result["summary_line"])
            result_preview.apply_mode(context.scene, context.scene.lapig.preview_mode, report=None)


class LAPIG_OT_look_nodes(NeedsTorch, ReportsErrors, bpy.types.Operator):
    """Make the world look a shader node group (Noise, Voronoi, Brick or Wave with the sliders' values, its colour
    ramp) and add it to the object's material, for the node editor"""
    bl_idname = "lapig.look_nodes"
    bl_label = "Look as Node Group"

    def execute(self, context):
        from ..lapig_addon.blender import look_nodes
        from ..lapig_core.export.result_files import read_summary

        scene = context.scene
        state = scene_state.read(scene)
        refuse(panel_state.result_blocker(state))
        group = look_nodes.build_group(_jobs("generate.look_edit").node_recipe_of(read_summary(state.result_dir)))
        node = look_nodes.add_to_material(scene_state.rig_objects(scene)[2], group)
        where = f"added to the material '{node.id_data.name}'" if node is not None else "in the file's node groups"
        self.report({"INFO"}, f"Node group '{group.name}' {where}")
        return {"FINISHED"}


class LAPIG_OT_render_result(NeedsTorch, JobRunnerMixin, bpy.types.Operator):
    """Project the generated image with Cycles and capture it, to see the real result"""
    bl_idname = "lapig.render_result"
    bl_label = "Render Real Capture"

    def make_job(self, context):
        return _jobs("render.render_job").RenderResultJob(scene_seams(context.scene))  # torch, as NeedsTorch says

    def on_done(self, context, job):
        m = job.result["metrics"]
        self.report({"INFO"}, f"Rendered capture: {m.get('rendered_psnr', float('nan')):.1f} dB against the target")


class LAPIG_OT_refine_result(NeedsTorch, JobRunnerMixin, bpy.types.Operator):
    """Refine the projector image on the rig: project it, capture it, correct it where the capture misses the
    target, until a step gains less than 0.05 dB or Refine steps is reached (Esc cancels and keeps the result)"""
    bl_idname = "lapig.refine_result"
    bl_label = "Refine on the Rig"

    def make_job(self, context):
        return _jobs("refine.refine_job").RefineResultJob(scene_seams(context.scene),
                                                          scene_state.refine_steps(context.scene))

    def on_done(self, context, job):
        self.report({"INFO"}, "Refined on the rig: " + job.result["line"])


class LAPIG_OT_preview_mode(ReportsErrors, bpy.types.Operator):
    """Show the original material, the projection, the target, the simulated or rendered capture"""
    bl_idname = "lapig.preview_mode"
    bl_label = "Preview"
    bl_options = {"REGISTER", "UNDO"}

    mode: bpy.props.EnumProperty(items=PREVIEW_MODES)

    def execute(self, context):
        if not result_preview.apply_mode(context.scene, self.mode, self.report):
            return {"CANCELLED"}
        scene_state.record_preview_mode(context.scene, self.mode)
        return {"FINISHED"}


class LAPIG_OT_show_comparison(ReportsErrors, bpy.types.Operator):
    """Open the with/without PSA comparison sheet in an Image Editor"""
    bl_idname = "lapig.show_comparison"
    bl_label = "Show PSA Comparison"

    def execute(self, context):
        folder = scene_state.read(context.scene).result_dir
        path = os.path.join(folder, "comparison.png") if folder else ""
        if not os.path.isfile(path):
            self.report({"ERROR"}, "Generate a projector image first")
            return {"CANCELLED"}
        image = bpy.data.images.load(path, check_existing=True)
        image.reload()
        show_in_image_editor(self, context, image, f"Comparison loaded as image '{image.name}': open it in an Image "
                                                   f"Editor")
        return {"FINISHED"}


class LAPIG_OT_export_image(ReportsErrors, bpy.types.Operator):
    """Write the projector image at the projector's native resolution, with a JSON sidecar"""
    bl_idname = "lapig.export_image"
    bl_label = "Export Projector Image"

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")

    def invoke(self, context, event):
        self.filepath = scene_state.export_settings(context.scene).path
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        from ..lapig_addon.services.export import export_result

        settings = scene_state.export_settings(context.scene, path=self.filepath or None)
        written = export_result.export_current(BlenderSceneStore(context.scene), settings)
        if "images" in written:  # several projectors: one image each
            self.report({"INFO"}, f"Exported {len(written['images'])} projector images: {', '.join(written['images'])}")
        else:
            self.report({"INFO"}, f"Exported {written['image']}")
        return {"FINISHED"}


class LAPIG_OT_export_mpcdi(ReportsErrors, bpy.types.Operator):
    """Write the rig's calibration (each projector's warp and blend from the capture) as an MPCDI package (2.0,
    or 1.0 for Watchout 6 and the VESA reference reader) for a media server (Watchout, BrightSign: the '2d'
    profile) or an engine (nDisplay, TouchDesigner: 'sl')"""
    bl_idname = "lapig.export_mpcdi"
    bl_label = "Export MPCDI Package"

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    profile: bpy.props.EnumProperty(
        name="Profile", default="2d",
        items=[("2d", "2D", "Each projector's warp (camera coordinates per pixel) and blend: Watchout, BrightSign"),
               ("sl", "Shader Lamp", "Each projector's pose, frustum and 3D surface point per 8th pixel, and blend: "
                                     "nDisplay, TouchDesigner")])
    version: bpy.props.EnumProperty(
        name="MPCDI version", default="2.0",
        items=[("2.0", "2.0", "MPCDI 2.0: Watchout 7, nDisplay, Pixera, TouchDesigner"),
               ("1.0", "1.0", "MPCDI 1.0: Watchout 6 and the VESA reference reader (which refuses 2.0); 8-bit maps")])

    def invoke(self, context, event):
        path = scene_state.export_settings(context.scene).path
        self.filepath = os.path.splitext(path)[0] + ".mpcdi"
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        from ..lapig_addon.services.export import export_result

        written = export_result.export_current(BlenderSceneStore(context.scene),
                                               scene_state.export_settings(context.scene),
                                               mpcdi=bpy.path.abspath(self.filepath), images=False,
                                               profile=self.profile, mpcdi_version=self.version)
        self.report({"INFO"}, f"Exported {written['mpcdi']} (MPCDI {self.version})")
        return {"FINISHED"}


class LAPIG_OT_export_crossfade(AsksForFolder, bpy.types.Operator):
    """Write a crossfade sequence from the look without PSA to the look with it (or from black)"""
    bl_idname = "lapig.export_crossfade"
    bl_label = "Export Crossfade"

    def execute(self, context):
        from ..lapig_addon.services.export import export_result

        paths = export_result.export_crossfade(BlenderSceneStore(context.scene), bpy.path.abspath(self.directory),
                                               scene_state.export_settings(context.scene))
        folders = sorted({os.path.dirname(p) for p in paths})  # several projectors: a folder each
        where = folders[0] if len(folders) == 1 else f"{os.path.dirname(folders[0])} (a folder per projector)"
        self.report({"INFO"}, f"Wrote {len(paths)} frames to {where}")
        return {"FINISHED"}


CLASSES = (LAPIG_OT_train_models, LAPIG_OT_train_background, LAPIG_OT_cancel_background_train,
           LAPIG_OT_generate, LAPIG_OT_edit_look, LAPIG_OT_look_nodes, LAPIG_OT_render_result, LAPIG_OT_refine_result,
           LAPIG_OT_preview_mode,
           LAPIG_OT_show_comparison, LAPIG_OT_export_image, LAPIG_OT_export_mpcdi, LAPIG_OT_export_crossfade)

register, unregister = bpy.utils.register_classes_factory(CLASSES)
