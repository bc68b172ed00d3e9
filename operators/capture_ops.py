import bpy

from ..lapig_addon.blender import scene_state, storage
from ..lapig_addon.blender.modal_runner import JobRunnerMixin, cancel_background
from ..lapig_addon.blender.operator_boundary import AsksForFolder, poll_reason
from ..lapig_addon.blender.scene_store import scene_seams
from ..lapig_addon.services.background_jobs import train_after_capture
from ..lapig_addon.services.capture.capture_job import CaptureJob, check_rig
from ..lapig_addon.services.panel.panel_state import capture_deps_blocker
from ..lapig_core.capture.dataset import load_capture_set, setup_dir_of, summarize
from ..lapig_core.optics.working_frame import check_aspect
from ..lapig_core.common.deps import require


class LAPIG_OT_capture(JobRunnerMixin, bpy.types.Operator):
    """Render the capture set (references, Gray code, training and test patterns) with Cycles"""
    bl_idname = "lapig.capture"
    bl_label = "Capture"
    replaces_models = True  # a Train in the background is cancelled first

    @classmethod
    def poll(cls, context):  # numpy and OpenCV, not torch: the classical first look is fitted without it
        return poll_reason(cls, capture_deps_blocker())

    def make_job(self, context):
        require("numpy", "cv2")
        seams = scene_seams(context.scene)
        check_rig(seams.store)
        _, temporary = storage.data_root()
        if temporary:
            self.report({"WARNING"}, storage.location_message())
        return CaptureJob(seams, seams.store.capture_settings())  # it records the capture in the scene

    def on_done(self, context, job):
        self.report({"INFO"}, job.line())
        # several projectors have no networks to train: their joint model is the first look
        if job.way.trains_networks and train_after_capture(job, self.ran_modal,
                                                           scene_state.train_in_background(context.scene)):
            try:
                bpy.ops.lapig.train_background("INVOKE_DEFAULT")
            except RuntimeError as exc:  # its ERROR report, raised back here: the capture itself is fine
                self.report({"WARNING"}, f"Training in the background did not start: {exc}")


class LAPIG_OT_import_capture(AsksForFolder, bpy.types.Operator):
    """Use a projector-camera capture folder made elsewhere (public compensation-dataset layout)"""
    bl_idname = "lapig.import_capture"
    bl_label = "Import Capture Folder"

    def execute(self, context):
        projector_size = scene_state.read_rig(context.scene).projector_size
        capture_set = load_capture_set(bpy.path.abspath(self.directory))
        if projector_size:  # its images must cover the projector's frame (e.g. a public 256x256 set: 1:1)
            check_aspect(capture_set.frame_size, projector_size, "the data set",
                         advice="set the projector's resolution to the data set's aspect first")
        cancel_background()  # a Train in the background works on the capture this replaces
        scene_state.record_capture(context.scene, setup_dir_of(capture_set), "")  # captured elsewhere: not tied to this rig
        self.report({"INFO"}, summarize(capture_set))
        return {"FINISHED"}


CLASSES = (LAPIG_OT_capture, LAPIG_OT_import_capture)

register, unregister = bpy.utils.register_classes_factory(CLASSES)
