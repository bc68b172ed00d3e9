import bpy

from ..lapig_addon.blender import storage
from ..lapig_addon.services.capture_job import CaptureJob, CaptureSettings, check_rig
from ..lapig_addon.blender.fingerprint import rig_fingerprint
from ..lapig_addon.blender.modal_runner import JobRunnerMixin
from ..lapig_core.capture.dataset import DatasetError, load_capture_set, summarize
from ..lapig_core.common.deps import require


class LAPIG_OT_capture(JobRunnerMixin, bpy.types.Operator):
    """Render the capture set (references, Gray code, training and test patterns) with Cycles"""
    bl_idname = "lapig.capture"
    bl_label = "Capture"

    def make_job(self, context):
        require("numpy", "cv2")
        scene = context.scene
        s = scene.lapig
        check_rig(scene, s.projector, s.camera, s.target)
        root, temporary = storage.data_root()
        if temporary:
            self.report({"WARNING"}, storage.location_message())
        name = storage.setup_name_for(s.target)
        settings = CaptureSettings(
            out_dir=storage.capture_root(name), setup_name=name, train_count=s.train_count,
            test_count=s.test_count, working_size=s.working_size, gray_level=s.gray_level,
            samples=s.samples, ambient=s.ambient, seed=s.seed,
            pattern_folder=bpy.path.abspath(s.pattern_folder) if s.pattern_source == "FOLDER" else None,
            chunk=2 if not bpy.app.background else 8)  # small chunks keep the UI responsive
        return CaptureJob(scene, s.projector, s.camera, s.target, settings)

    def on_done(self, context, job):
        s = context.scene.lapig
        s.last_capture_dir = str(job.result["setup_dir"])
        s.last_capture_fingerprint = job.result["meta"]["fingerprint"]
        reg = job.result["meta"]["registration"]
        err = reg.get("registration_error_px_median")
        extra = f", registration error {err:.2f} px" if err is not None else ""
        self.report({"INFO"}, f"Captured into {s.last_capture_dir}{extra}")


class LAPIG_OT_import_capture(bpy.types.Operator):
    """Use a projector-camera capture folder made elsewhere (public compensation-dataset layout)"""
    bl_idname = "lapig.import_capture"
    bl_label = "Import Capture Folder"

    directory: bpy.props.StringProperty(subtype="DIR_PATH")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        try:
            capture_set = load_capture_set(bpy.path.abspath(self.directory))
        except (DatasetError, OSError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        s = context.scene.lapig
        s.last_capture_dir = str(capture_set.root / "setups" / capture_set.setup) \
            if capture_set.setup else self.directory
        s.last_capture_fingerprint = ""  # captured elsewhere: not tied to this scene's rig
        self.report({"INFO"}, summarize(capture_set))
        return {"FINISHED"}


def capture_state(scene) -> tuple[str, str]:
    """('MISSING'|'STALE'|'DONE', reason) for the panel."""
    s = scene.lapig
    if not s.last_capture_dir:
        return "MISSING", "No capture yet"
    if s.last_capture_fingerprint and s.projector and s.camera and s.target:
        if rig_fingerprint(s.projector, s.camera, s.target) != s.last_capture_fingerprint:
            return "STALE", "The rig or the object changed since the capture"
    return "DONE", s.last_capture_dir


CLASSES = (LAPIG_OT_capture, LAPIG_OT_import_capture)

register, unregister = bpy.utils.register_classes_factory(CLASSES)
