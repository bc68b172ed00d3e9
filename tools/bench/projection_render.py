"""Project images onto the rendered surface and capture them, for scripts and benchmarks that hold the
rig's objects: services/capture/projection through the Cycles device factory of those objects."""
from __future__ import annotations

from ...lapig_addon.services.capture.projection import project_and_capture, register_at  # noqa: F401 (register_at re-exported)
from ...lapig_addon.blender.cycles_factory import CyclesDeviceFactory


def render_working_images(scene, projector, camera, target, setup_dir, images, seed=0, chunk=8,
                          return_raw=False, bit_depth=8):
    """Registered captures (N, h, w, 3) float32 at the setup's working frame of projecting each
    image (N, H, W, 3: working frames, or native ones), sent to the projector as bit_depth frames
    (ProjectorModel.frame_light, like the exported file)."""
    registered, raw = project_and_capture(CyclesDeviceFactory(scene, projector, camera, target), setup_dir, images,
                                          seed=seed, chunk=chunk, bit_depth=bit_depth)
    return (registered, raw) if return_raw else registered
