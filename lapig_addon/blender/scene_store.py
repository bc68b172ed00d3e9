"""Blender's scene store: the jobs' settings read from scene.lapig and the rig objects, and what the jobs
made recorded there (services/ports.SceneStore over blender/scene_state)."""
from __future__ import annotations

import bpy

from . import scene_state, storage
from .cycles_factory import CyclesDeviceFactory
from .result_sinks import ProjectorLightSink
from ..services.export.export_result import result_frame
from ..services.ports import Seams


class BlenderSceneStore:
    def __init__(self, scene):
        self.scene = scene

    def read(self):
        return scene_state.read(self.scene)

    def capture_settings(self, **overrides):
        return scene_state.capture_settings(self.scene, **overrides)

    def generate_request(self, **overrides):
        return scene_state.generate_request(self.scene, **overrides)

    def export_settings(self, **overrides):
        return scene_state.export_settings(self.scene, **overrides)

    def finetune_iterations(self):
        return scene_state.finetune_iterations(self.scene)

    def compute_device(self) -> str:
        return scene_state.compute_device()

    def projector_model(self):
        return scene_state.projector_model(scene_state.rig_objects(self.scene)[0])

    def projector_models(self) -> tuple:
        """Every projector's model, the first first (a rig of several: its crossfades, each in its own gamma)."""
        return tuple(scene_state.projector_model(p) for p in scene_state.rig_projectors(self.scene))

    def rig_metadata(self) -> dict:
        return scene_state.rig_metadata(self.scene)

    def sl_geometry(self, step: int = 8) -> dict:
        """The 'sl' MPCDI package's scene data, gathered here on the main thread: each projector's model, world
        matrix and texels' surface points (geometry_probe.sl_rig_geometry)."""
        from .geometry_probe import sl_rig_geometry

        objects = scene_state.rig_projectors(self.scene)
        models = [scene_state.projector_model(ob) for ob in objects]
        return {"models": models, **sl_rig_geometry(self.scene, objects, models, step)}

    def software(self) -> dict:
        return {"software_blender": bpy.app.version_string}

    def data_root(self) -> str:
        return storage.data_root()[0]

    def look_geometry(self, width: int, height: int):
        """Ray cast from the projector into the scene (blender/look_geometry), here on the main thread; None on a
        real rig: its scene's objects are no model of the surface."""
        if scene_state.uses_real_rig(self.scene):
            return None
        from .look_geometry import projector_look_geometry

        projector = scene_state.rig_objects(self.scene)[0]
        return projector_look_geometry(self.scene, projector, scene_state.projector_model(projector), width, height)

    def camera_look_geometry(self, long_side: int):
        """As look_geometry, from the rig's camera at its resolution scaled to a long side of `long_side` (the
        looks of a rig of several projectors are made in the camera's space)."""
        if scene_state.uses_real_rig(self.scene):
            return None
        from .look_geometry import camera_look_geometry

        camera = scene_state.rig_objects(self.scene)[1]
        if camera is None:
            return None
        c = scene_state.camera_settings(camera)
        scale = min(1.0, long_side / max(c.width, c.height))
        return camera_look_geometry(self.scene, camera, max(8, round(c.width * scale)), max(8, round(c.height * scale)))

    def record_capture(self, folder, fingerprint: str, transport: str = ""):
        scene_state.record_capture(self.scene, folder, fingerprint, transport)

    def record_coverage(self, names, shares, reached: float):
        scene_state.record_coverage(self.scene, names, shares, reached)

    def record_models(self, fingerprint: str, status: str | None = None):
        scene_state.record_models(self.scene, fingerprint, status)

    def record_result(self, folder, summary_line: str, reach_message: str = ""):
        scene_state.record_result(self.scene, folder, summary_line, reach_message)


def device_factory(scene, projector=None, camera=None, target=None):
    """The scene's rig: its real projector and camera where it has one (scene.lapig.rig_kind), else the
    Cycles studio of its objects (or of the given ones)."""
    spec = scene_state.real_rig_spec(scene) if projector is None else None
    if spec is None:
        return CyclesDeviceFactory(scene, projector, camera, target)
    from ..rigs.real_rig import RealRigFactory

    rig = scene_state.read_rig(scene)
    # every projector's (name, display, size): rig.displays names each one's where the rig has several, none for
    # one projector (its display is the spec's)
    several = tuple(zip(rig.projectors, rig.displays, rig.projector_sizes))
    return RealRigFactory(spec, expected_size=rig.projector_size, projectors=several)


def scene_seams(scene, projector=None, camera=None, target=None, sinks=None, devices=None) -> Seams:
    """What the jobs run against in Blender: this scene's store, its rig's device factory (devices: another
    one, e.g. a simulated rig) and the projector light with the preview (sinks=(): none), plus the live
    projector window where one is open (rigs/live_output)."""
    if sinks is None:
        from ..rigs.live_output import open_sinks

        sinks = (ProjectorLightSink(scene), *open_sinks())
    return Seams(BlenderSceneStore(scene), devices or device_factory(scene, projector, camera, target), tuple(sinks))


def scene_result_frame(scene):
    """The scene's stored result as a ProjectorFrame at the export's bit depth (what Export writes); None
    without a result or a projector."""
    folder = scene_state.read(scene).result_dir
    if not folder or scene_state.rig_objects(scene)[0] is None:
        return None
    store = BlenderSceneStore(scene)
    return result_frame(store, folder, store.export_settings().bit_depth)


def show_scene_result(scene) -> bool:
    """The light emits the scene's stored result at the export bit depth (after the bit depth changed);
    False without a result."""
    frame = scene_result_frame(scene)
    if frame is None:
        return False
    ProjectorLightSink(scene).show(frame)
    return True
