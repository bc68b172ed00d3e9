"""Operators of a real projector and camera: find the devices, choose them, check the rig, the camera's
live picture, the live projector window and a crossfade played on it."""
import bpy

from ..lapig_addon.blender import live_devices, scene_state
from ..lapig_addon.blender.modal_runner import JobRunnerMixin
from ..lapig_addon.blender.operator_boundary import ReportsErrors, refuse, report_notes, show_in_image_editor
from ..lapig_addon.blender.scene_store import BlenderSceneStore, scene_seams
from ..lapig_addon.rigs import device_list, live_output
from ..lapig_addon.services.panel import panel_state
from ..lapig_addon.services.capture.rig_check import RigCheckJob

_ITEMS = {"display": [], "camera": []}  # Blender needs the enum strings to stay referenced
NOTHING = ("NONE", "Nothing found yet: Find Displays and Cameras", "")


def _items(kind):
    found = device_list.found()
    items = (found.display_items() if kind == "display" else found.camera_items()) if found else []
    _ITEMS[kind][:] = items or [NOTHING]
    return _ITEMS[kind]


class LAPIG_OT_find_devices(JobRunnerMixin, bpy.types.Operator):
    """List the displays (for the projector window) and the cameras of this computer"""
    bl_idname = "lapig.find_devices"
    bl_label = "Find Displays and Cameras"

    def make_job(self, context):
        return device_list.FindDevicesJob()

    def on_done(self, context, job):
        report_notes(self, job.result.problems)
        self.report({"INFO"}, job.result.summary())


class ChoosesDevice(ReportsErrors):
    """Mixin of Choose Display and Choose Camera: bl_property names the enum ('display' or 'camera')."""
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    def execute(self, context):
        kind = self.bl_property
        chosen = getattr(self, kind)
        if chosen == NOTHING[0]:
            self.report({"ERROR"}, f"Find the {kind}s first (Find Displays and Cameras)")
            return {"CANCELLED"}
        scene_state.choose_real_device(context.scene, **{kind: chosen})
        return {"FINISHED"}


class LAPIG_OT_choose_display(ChoosesDevice, bpy.types.Operator):
    """The projector's display, among those found"""
    bl_idname = "lapig.choose_display"
    bl_label = "Choose Display"
    bl_property = "display"

    display: bpy.props.EnumProperty(name="Display", items=lambda self, context: _items("display"))


class LAPIG_OT_choose_camera(ChoosesDevice, bpy.types.Operator):
    """The camera, among those found"""
    bl_idname = "lapig.choose_camera"
    bl_label = "Choose Camera"
    bl_property = "camera"

    camera: bpy.props.EnumProperty(name="Camera", items=lambda self, context: _items("camera"))


class LAPIG_OT_check_rig(JobRunnerMixin, bpy.types.Operator):
    """Open the real projector and camera and measure the latency, find the frame code, check the exposure
    and a gray ramp (nothing is captured)"""
    bl_idname = "lapig.check_rig"
    bl_label = "Check the Rig"

    def make_job(self, context):
        seams = scene_seams(context.scene)
        rig = seams.store.read().rig
        if rig.kind != "REAL":
            raise ValueError("Check the Rig checks a real projector and camera: set Rig to Real rig")
        refuse(panel_state.device_blocker(rig))
        return RigCheckJob(seams, seams.store.capture_settings())

    def on_done(self, context, job):
        report_notes(self, job.result.problems)
        if job.result.ok:
            self.report({"INFO"}, "The rig passed its checks: " + "; ".join(line.label() for line in job.result.lines))


class LAPIG_OT_camera_view(ReportsErrors, bpy.types.Operator):
    """Show the real camera's live picture in the image 'LAPIG camera view' (open it in an Image Editor);
    again to stop"""
    bl_idname = "lapig.camera_view"
    bl_label = "Camera View"

    def execute(self, context):
        if live_devices.camera_view_running():
            live_devices.stop_camera_view()
            self.report({"INFO"}, "Camera view stopped")
            return {"FINISHED"}
        live_devices.start_camera_view(context.scene)
        image = live_devices.camera_image()
        show_in_image_editor(self, context, image, f"Camera view in the image '{image.name}': open it in an Image "
                                                   f"Editor")
        return {"FINISHED"}


class LAPIG_OT_show_on_projector(JobRunnerMixin, bpy.types.Operator):
    """Open the projector window on the real rig's display with the current look; every Generate then shows
    its look there too. Again (or Esc in the window) to close it"""
    bl_idname = "lapig.show_on_projector"
    bl_label = "Show on Projector"

    def execute(self, context):
        if live_output.open_sinks():
            return self._close()
        return JobRunnerMixin.execute(self, context)

    def invoke(self, context, event):
        if live_output.open_sinks():
            return self._close()
        return JobRunnerMixin.invoke(self, context, event)

    def make_job(self, context):
        return live_devices.projector_job(context.scene)  # the window opens on the job's worker thread

    def on_done(self, context, job):
        live_devices.projector_opened()
        sink = job.result
        if sink.problem:
            self.report({"WARNING"}, sink.problem)
        w, h = sink.window.size
        self.report({"INFO"}, f"Projector window open, {w}x{h}: Esc in it closes it")

    def _close(self):
        live_devices.close_projector(wait=False)
        self.report({"INFO"}, "Projector window closed")
        return {"FINISHED"}


class LAPIG_OT_play_crossfade(JobRunnerMixin, bpy.types.Operator):
    """Play the crossfade from the look without PSA to the look with it on the projector window"""
    bl_idname = "lapig.play_crossfade"
    bl_label = "Play Crossfade"

    @classmethod
    def waits_for(cls, context):
        if not live_output.open_sinks():
            return "Show on Projector first: the crossfade plays in the projector window"
        return panel_state.result_blocker(scene_state.read(context.scene))

    def make_job(self, context):
        scene = context.scene
        sinks = live_output.open_sinks()
        if not sinks:
            raise ValueError("Show on Projector first: the crossfade plays in the projector window")
        state = scene_state.read(scene)
        refuse(panel_state.result_blocker(state))
        settings = scene_state.export_settings(scene)
        job = live_output.CrossfadeJob(sinks[-1], BlenderSceneStore(scene), state.result_dir,
                                       settings.crossfade_frames, scene.lapig.crossfade_fps, settings.bit_depth)
        job.check()  # the sizes and the images, read now: a refusal before anything plays
        return job

    def on_done(self, context, job):
        played = job.result
        late = f", {played['late_frames']} late" if played["late_frames"] else ""
        self.report({"INFO"}, f"Played {played['frames']} frames in {played['seconds']:.2f} s{late}")


class LAPIG_OT_report_message(ReportsErrors, bpy.types.Operator):
    """Say a message in the report area (for timers, which have no operator of their own)"""
    bl_idname = "lapig.report_message"
    bl_label = "LAPIG Message"
    bl_options = {"INTERNAL"}

    kind: bpy.props.EnumProperty(items=[(k, k.title(), "") for k in ("INFO", "WARNING", "ERROR")])
    message: bpy.props.StringProperty()

    def execute(self, context):
        self.report({self.kind}, self.message)
        return {"FINISHED"}


CLASSES = (LAPIG_OT_find_devices, LAPIG_OT_choose_display, LAPIG_OT_choose_camera, LAPIG_OT_check_rig,
           LAPIG_OT_camera_view, LAPIG_OT_show_on_projector, LAPIG_OT_play_crossfade, LAPIG_OT_report_message)

register, unregister = bpy.utils.register_classes_factory(CLASSES)
