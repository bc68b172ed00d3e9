"""The Cycles capture studio as a capture device: a virtual projector and camera.

The projector's light transfer (gamma, black level) turns each 8-bit frame into the relative
light the studio's spot light emits; Cycles renders linear light in batches (an image sequence
per capture() call), and the camera response (exposure, noise, 8 bits) makes the saved image.
"""
from __future__ import annotations

import bpy
import numpy as np

from ...lapig_core.capture.device import CaptureDevice, DeviceInfo
from ...lapig_core.capture.sequence import GeometryChecks
from ...lapig_core.optics.camera_model import CameraResponse, auto_exposure_stops
from ...lapig_core.optics import transport as light
from .capture_studio import CaptureStudio
from .geometry_probe import RigGeometry, projector_axial_depth, renderable_objects, scene_bvh
from .scene_state import camera_settings, light_transport, projector_model


class CyclesCaptureDevice(CaptureDevice):
    def __init__(self, scene, projector, camera, target, samples=1, ambient=0.03, seed=0,
                 response: CameraResponse | None = None, camera_size: tuple[int, int] | None = None,
                 transport: light.LightTransport | None = None):
        """response, camera_size: a setup's recorded camera (Render Real Capture judges a projection
        as that setup's captures were taken); None: the camera's own settings.
        transport: how light travels (None: the rig's own setting, scene_state.light_transport)."""
        self.scene, self.projector, self.camera, self.target = scene, projector, camera, target
        # an evaluation brings matrix_world up to date after a script moved the rig
        bpy.context.evaluated_depsgraph_get()
        self.model = projector_model(projector)
        self.camera_settings = camera_settings(camera)
        self.width, self.height = camera_size or (self.camera_settings.width, self.camera_settings.height)
        # the camera's exposure stays fixed, until lock_exposure
        self.response = response or self.camera_settings.response()
        self.rng = np.random.default_rng(seed)  # the camera's sensor noise
        self.samples, self.ambient = samples, ambient
        distance = float(np.linalg.norm(np.array(projector.matrix_world.translation)
                                        - np.array(target.matrix_world.translation)))
        self.transport = transport or light_transport(projector, camera)
        self.studio = CaptureStudio(scene, projector, camera, self.width, self.height, samples=samples,
                                    ambient=ambient, ambient_distance=distance, transport=self.transport,
                                    seed=seed)
        self._shown = None
        self._blur_radius = None  # projector pixels' circle of confusion, with projector defocus
        self._vignetting = None

    def __enter__(self):
        self.studio.__enter__()
        try:
            self._prepare_lenses()
        except Exception:
            self.studio.close()
            raise
        return self

    def _prepare_lenses(self):
        t = self.transport
        if t.uses_projector_defocus:
            bvh = scene_bvh(renderable_objects(self.scene), bpy.context.evaluated_depsgraph_get())
            depth = projector_axial_depth(bvh, self.projector, self.model)
            focal_px = self.model.width * self.model.throw_ratio
            self._blur_radius = light.blur_radius_px(depth, t.projector_focus_m, t.projector_lens_radius_mm / 1000,
                                                     focal_px).astype(np.float32)
        if t.uses_vignetting:
            cam = self.camera.data
            half_tan = cam.sensor_width / (2 * cam.lens)  # sensor fit is horizontal (rig.create_camera)
            self._vignetting = light.vignetting_map(self.width, self.height, half_tan, t.vignetting)[..., None]

    def _emitted(self, frame) -> np.ndarray:
        """The light the projector's lens puts on the surface for one input frame."""
        emitted = self.model.emitted_8bit(frame) if frame.dtype == np.uint8 else self.model.emitted(frame)
        if self._blur_radius is not None:
            emitted = light.defocus_frame(emitted, self._blur_radius)
        return emitted

    def _linear(self, frames) -> list[np.ndarray]:
        linear = self.studio.render([self._emitted(f) for f in frames])
        if self._vignetting is not None:
            linear = [x * self._vignetting for x in linear]
        return linear

    def close(self):
        self.studio.close()

    def vary_noise(self, draw: int) -> None:
        """Cycles' sampling seed of the studio's own scene (gone with it on close) moves on by `draw`."""
        if self.studio.scene is not None:
            self.studio.scene.cycles.seed = (self.studio.seed + 7919 * draw) % (2 ** 31)

    def describe(self) -> DeviceInfo:
        return DeviceInfo("Blender Cycles", (self.model.width, self.model.height), (self.width, self.height), {
            "projector": self.model.to_dict(),
            "camera": {"resolution": [self.width, self.height], "response": self.response.to_dict(),
                       "lens_mm": self.camera.data.lens, "auto_exposure": self.camera_settings.auto_exposure},
            "ambient": self.ambient,
            "samples": self.samples,
            "transport": self.transport.to_dict(),
            "blender": bpy.app.version_string,
        })

    def geometry_checks(self) -> GeometryChecks:
        """Coverage and exact registration by ray casting the scene (needs the open studio)."""
        rig = RigGeometry(self.scene, self.projector, self.camera, self.target, self.model, self.studio.scene,
                          self.width, self.height)
        return GeometryChecks(surface=f"'{self.target.name}'",
                              aim_hint="aim the projector and the camera at the object, "
                                       "or use 'Add projector and camera'",
                              coverage=rig.coverage, exact_projector_to_camera=rig.exact_projector_to_camera)

    def lock_exposure(self, white_frame):
        """Auto exposure: the camera's setting, from a linear render of the white frame."""
        if self.camera_settings.auto_exposure:
            linear = self._linear([white_frame])[0]
            stops = auto_exposure_stops(linear, mask=linear.max(-1) > 1e-6)
            self.response = self.camera_settings.response(stops)

    def show(self, frame):
        self._shown = frame

    def grab(self):
        return self.capture([self._shown])[0]

    def capture(self, frames):
        """One Cycles animation render for the whole batch (uint8 frames, or uint16 ones where the
        exported file is 16-bit)."""
        linear = self._linear(frames)
        return [self.response.capture(x, self.rng) for x in linear]
