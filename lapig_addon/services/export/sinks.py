"""Result sinks that need no Blender: the exported projector image file (PNG and JSON sidecar)."""
from __future__ import annotations

from ....lapig_core.export import projector_image as export
from ..ports import ProjectorFrame


class ProjectorImageFile:
    """Writes the frame's pixels at the projector's native resolution to `path`, with a JSON sidecar of
    `metadata`; `written` holds what export_projector_image returned ({'image': Path, 'sidecar': Path})."""

    def __init__(self, path, metadata: dict, lapig_version: str):
        self.path, self.metadata, self.lapig_version = path, metadata, lapig_version
        self.written: dict | None = None

    def show(self, frame: ProjectorFrame) -> None:
        self.written = export.export_projector_image(self.path, frame.image, frame.width, frame.height,
                                                     bit_depth=frame.bit_depth, metadata=self.metadata,
                                                     lapig_version=self.lapig_version)
