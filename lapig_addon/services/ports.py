"""The three seams every job runs against: a scene store, a device factory and result sinks.

- SceneStore: reads the request and the settings as the plain values of services/state.py and
  records what the jobs made (the capture, the models, the result). Blender's is
  blender/scene_store.BlenderSceneStore (scene.lapig and the rig objects).
- DeviceFactory: opens the capture device of the rig, as it is now (Capture) or as a capture
  recorded it (Train's rendered choice, Render Real Capture), and gives the rig's identity.
  Blender's is blender/cycles_factory.CyclesDeviceFactory; a real projector and camera are one more.
- ResultSink: receives a generated projector frame. Blender's light and preview is
  blender/result_sinks.ProjectorLightSink; the exported file is services/export/sinks.ProjectorImageFile;
  a live projector window is one more.

Nothing here imports bpy: tests/addon drives the jobs end to end with fakes of all three.
"""
from __future__ import annotations

import hashlib
import json
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import numpy as np

from ...lapig_core.capture.device import CaptureDevice
from ...lapig_core.capture.settings import CaptureSettings
from ...lapig_core.optics.projector_model import ProjectorModel, quantised_frame
from .state import ExportSettings, GenerateRequest, SceneState


@dataclass(frozen=True)
class RigIdentity:
    """Which rig a capture was made with: what a real rig can say of itself (its name, its devices'
    descriptions), and the host's own hash of the rig's state where it has one (Blender's fingerprint of
    the objects, blender/fingerprint.py). key() is what setup.json records as the capture's fingerprint
    and what staleness compares."""
    name: str
    devices: dict = field(default_factory=dict)
    fingerprint: str = ""

    def key(self) -> str:
        if self.fingerprint:
            return self.fingerprint
        text = json.dumps({"name": self.name, "devices": self.devices}, sort_keys=True, default=str)
        return hashlib.sha1(text.encode()).hexdigest()[:16]

    def to_dict(self) -> dict:
        return {"name": self.name, "devices": self.devices, "key": self.key()}


class SceneStore(Protocol):
    """The scene's settings in and the jobs' products out."""

    def read(self) -> SceneState: ...

    def capture_settings(self, **overrides) -> CaptureSettings: ...

    def generate_request(self, **overrides) -> GenerateRequest: ...

    def export_settings(self, **overrides) -> ExportSettings: ...

    def finetune_iterations(self) -> int | None: ...

    def compute_device(self) -> str:
        """Where torch runs: 'auto' (a GPU where torch has one, else the CPU) or 'cpu'; the add-on's preference."""

    def projector_model(self) -> ProjectorModel: ...

    def projector_models(self) -> tuple:
        """Every projector's ProjectorModel, the first first (one for a rig of one)."""

    def rig_metadata(self) -> dict:
        """The rig as an exported image's sidecar describes it."""

    def software(self) -> dict:
        """The host's name and version for sidecars, e.g. {'software_blender': '5.0.1'}."""

    def data_root(self) -> str:
        """Where this scene's captures and results live."""

    def look_geometry(self, width: int, height: int):
        """The object as the (first) projector sees it at a width x height frame, for the looks of the world
        (lapig_core/lgst/world/geometry.LookGeometry), or None where there is no 3D model to read (a real rig):
        the look then follows the captured surface. Optional: a store without it counts as None."""

    def camera_look_geometry(self, long_side: int):
        """As look_geometry, the object as the rig's camera sees it (a rig of several projectors makes its look in
        the camera's space), at the camera's aspect and a long side of `long_side`. Optional, as look_geometry."""

    def record_capture(self, folder: str, fingerprint: str, transport: str = "") -> None: ...

    def record_coverage(self, names, shares, reached: float) -> None:
        """Several projectors: each one's share of the object at the capture just recorded, and together."""

    def record_models(self, fingerprint: str, status: str | None = None) -> None: ...

    def record_result(self, folder: str, summary_line: str, reach_message: str = "") -> None: ...


class DeviceFactory(Protocol):
    """The rig's capture device. `main_thread`: its devices must be opened and driven on Blender's main
    thread (Cycles); False: the jobs drive them on a worker thread, so a blocking grab() never freezes
    the UI."""

    main_thread: bool
    # the factory declares whether its multi_capture_device(settings) opens every projector of the rig at once and
    # the one camera (a MultiProjectorDevice: the joint strategy's capture, refinement, render and check); False: a
    # rig that captures one projector, refused in one line where several are asked for
    opens_several: bool

    def rig_identity(self) -> RigIdentity: ...

    def capture_device(self, settings: CaptureSettings) -> AbstractContextManager[CaptureDevice]:
        """The rig as it is now, for a capture with these settings."""

    def setup_device(self, setup_meta: dict, seed: int = 0) -> AbstractContextManager[CaptureDevice]:
        """The rig as a capture recorded it (setup.json's meta: its camera, exposure, ambient, samples),
        so a projection is judged as that capture's images were taken."""


@dataclass(frozen=True)
class ProjectorFrame:
    """A result's projector image on its way to a projector: the stored image (working or native frame),
    the projector's native size and the bit depth it is sent at. `pixels` is quantised_frame of it, the
    one placement and rounding that the light, the file and the render share."""
    image: np.ndarray
    width: int
    height: int
    bit_depth: int
    folder: str = ""  # the result folder it belongs to
    summary: dict = field(default_factory=dict, compare=False)
    projector_index: int = 0  # which of the rig's projectors shows it (0: the first, the only one of most rigs)

    @cached_property
    def pixels(self) -> np.ndarray:
        return quantised_frame(self.image, self.width, self.height, self.bit_depth)


class ResultSink(Protocol):
    """Where a generated projector frame goes: Blender's projector light, a file, a live window. A sink whose
    `several_projectors` is True takes frames for any of the rig's projectors (ProjectorFrame.projector_index);
    the others are shown the frames of one-projector results only."""

    def show(self, frame: ProjectorFrame) -> None: ...


@dataclass
class Seams:
    """What one job runs against: the scene store, the device factory and the result sinks."""
    store: SceneStore
    devices: DeviceFactory | None = None
    sinks: tuple = ()

    def show(self, frame: ProjectorFrame) -> None:
        for sink in self.sinks:
            sink.show(frame)
