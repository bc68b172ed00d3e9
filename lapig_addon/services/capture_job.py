"""Capture a complete, registered data set of one projector-camera setup with Cycles.

References (black -> I-, white -> I+, gray -> s), Gray code at the projector's native
resolution, then training and test patterns; every capture is registered into projector space
and written in the public layout (lapig_core.dataset).
"""
from __future__ import annotations

import os
import shutil
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from ...lapig_core.capture import dataset as ds
from ...lapig_core.capture import patterns as pat
from ...lapig_core.optics.camera_model import auto_exposure_stops, clipped_fraction
from ...lapig_core.common.imageio import read_image, write_png
from ...lapig_core.optics.projector_model import frame_from_working_image
from ...lapig_core.capture.registration import Registration
from ...lapig_core.capture.registration_check import registration_error_px, summarize_errors
from ...lapig_core.capture.structured_light import decode_graycode, graycode_patterns, projector_to_camera_map
from ..blender import geometry_probe as probe
from ..blender import preview, projector_nodes
from ..blender.capture_studio import CaptureStudio
from ..blender.fingerprint import rig_fingerprint
from .jobs import Job
from ..blender.scene_state import camera_response, projector_model, read_rig
from .panel_state import rig_blocker


def emitted_frame(model, working_image):
    """What the projector emits for a working image shown in its central square."""
    return model.emitted_8bit(frame_from_working_image(working_image, model.width, model.height))


class CaptureError(ValueError):
    """A capture that cannot start or go on, with a message the user can act on."""


@dataclass
class CaptureSettings:
    out_dir: str
    setup_name: str = "setup"
    train_count: int = 32
    test_count: int = 8
    working_size: int = 256
    gray_level: float = 0.5
    samples: int = 1
    ambient: float = 0.03
    pattern_folder: str | None = None
    seed: int = 0
    chunk: int = 8
    min_coverage: float = 0.5
    check_registration: bool = True
    check_grid_step: int = 4
    timings: dict = field(default_factory=dict)


def check_rig(scene, projector=None, camera=None, target=None):
    """CaptureError unless the rig of these objects (None: the scene's own) can be captured."""
    blocker = rig_blocker(read_rig(scene, projector, camera, target))
    if blocker:
        raise CaptureError(blocker)


def check_shared_patterns(layout, train, test):
    """The public layout shares prj/{train,test} between the setups of a root: never overwrite
    another setup's projector images with different ones (its captures would stop matching)."""
    others = [p for p in (layout.root / "setups").glob("*")
              if p.is_dir() and p.name != layout.setup and not p.name.endswith(".partial")] \
        if (layout.root / "setups").is_dir() else []
    if not others:
        return
    for kind, images in (("train", train), ("test", test)):
        existing = ds.list_images(layout.prj_dir(kind)) if layout.prj_dir(kind).is_dir() else []
        for path, image in zip(existing, images):
            if np.abs(read_image(path) - np.round(np.clip(image, 0, 1) * 255) / 255).max() > 1 / 255:
                raise CaptureError(
                    f"the folder {layout.root} holds other setups ({', '.join(p.name for p in others[:3])}) "
                    f"captured with different projector images: capture into another folder, or use the "
                    f"same pattern seed or folder as they did")


class CaptureJob(Job):
    title = "LAPIG capture"

    def __init__(self, scene, projector, camera, target, settings: CaptureSettings):
        super().__init__()
        self.scene, self.projector, self.camera, self.target = scene, projector, camera, target
        self.settings = settings

    def steps(self):
        s = self.settings
        check_rig(self.scene, self.projector, self.camera, self.target)
        model = projector_model(self.projector)
        cam_w, cam_h = self.camera.lapig_camera.resolution_x, self.camera.lapig_camera.resolution_y
        if s.pattern_folder:
            images = pat.load_image_folder(s.pattern_folder, size=s.working_size,
                                           count=s.train_count + s.test_count)
            if len(images) < s.train_count + s.test_count:
                raise CaptureError(f"the pattern folder has {len(images)} images, "
                                   f"{s.train_count + s.test_count} are needed")
        else:
            images = pat.generate_patterns(s.train_count + s.test_count, size=s.working_size, seed=s.seed)
        final_layout = ds.DatasetLayout(s.out_dir, s.setup_name)
        check_shared_patterns(final_layout, images[:s.train_count], images[s.train_count:])
        # write into '<name>.partial' and swap it in at the end: a cancel or a crash never leaves
        # a half-written setup where a complete one is expected
        layout = ds.DatasetLayout(s.out_dir, s.setup_name + ".partial")
        shutil.rmtree(layout.setup_dir, ignore_errors=True)
        # the viewport preview tints the object's materials: capture the real surface
        previewing = preview.current_preview(self.target)
        if previewing:
            preview.disable_preview(self.target)
        try:
            yield from self._capture(s, model, cam_w, cam_h, images, layout, final_layout)
        finally:
            shutil.rmtree(layout.setup_dir, ignore_errors=True)
            if previewing:
                image, appearance = previewing
                preview.enable_preview(self.target, self.projector,
                                       image or projector_nodes.projected_image(self.projector.data), appearance)

    def _capture(self, s, model, cam_w, cam_h, images, layout, final_layout):
        rng = np.random.default_rng(s.seed)
        timings = s.timings
        t0 = time.perf_counter()
        yield 0.01, "preparing the capture"

        depsgraph = bpy.context.evaluated_depsgraph_get()
        bvh = probe.scene_bvh(probe.renderable_objects(self.scene), depsgraph)
        target_bvh = probe.scene_bvh([self.target], depsgraph)
        centre = np.array(self.target.matrix_world.translation)
        distance = float(np.linalg.norm(np.array(self.projector.matrix_world.translation) - centre))
        with CaptureStudio(self.scene, self.projector, self.camera, cam_w, cam_h, samples=s.samples,
                           ambient=s.ambient, ambient_distance=distance) as studio:
            cam_proj = probe.CameraProjection(self.camera, studio.scene, cam_w, cam_h)
            cover = probe.coverage(bvh, self.projector, model, cam_proj, target_bvh)
            if min(cover.values()) < s.min_coverage:
                raise CaptureError(
                    f"'{self.target.name}' covers {cover['projector_on_object']:.0%} of the projector's "
                    f"working area and the camera sees {cover['seen_by_camera']:.0%} of it (at least "
                    f"{s.min_coverage:.0%} needed): aim the projector and the camera at the object, "
                    f"or use 'Add projector and camera'")
            yield 0.03, f"coverage {cover['projector_on_object']:.0%}: rendering references"

            # references, in the same central-square layout as the training images
            refs = pat.reference_patterns(size=s.working_size, gray_level=s.gray_level)
            ref_images = [refs["black"], refs["white"], refs["gray"]]
            t = time.perf_counter()
            ref_linear = studio.render([emitted_frame(model, im) for im in ref_images])
            if self.camera.lapig_camera.auto_exposure:
                stops = auto_exposure_stops(ref_linear[1], mask=ref_linear[1].max(-1) > 1e-6)
            else:
                stops = self.camera.lapig_camera.exposure
            response = camera_response(self.camera, stops)
            ref_caps = [response.capture(x, rng) for x in ref_linear]
            white_clipped = clipped_fraction(ref_caps[1], ref_linear[1].max(-1) > 1e-6)
            timings["references_s"] = time.perf_counter() - t
            yield 0.06, "rendering Gray-code patterns"

            # structured light at native resolution
            t = time.perf_counter()
            sl_patterns = graycode_patterns(model.width, model.height)
            sl_caps = []
            for start in range(0, len(sl_patterns), s.chunk):
                chunk = sl_patterns[start:start + s.chunk]
                frames = [model.emitted_8bit(p) for p in chunk]
                sl_caps += [response.capture(x, rng) for x in studio.render(frames)]
                yield 0.06 + 0.3 * len(sl_caps) / len(sl_patterns), \
                    f"structured light {len(sl_caps)}/{len(sl_patterns)}"
            timings["structured_light_render_s"] = time.perf_counter() - t
            t = time.perf_counter()
            decoded = decode_graycode(sl_caps, model.width, model.height)
            cam_xy, valid = projector_to_camera_map(decoded, model.width, model.height)
            registration = Registration.from_map(cam_xy, valid, model.width, model.height, s.working_size)
            timings["registration_build_s"] = time.perf_counter() - t
            valid_fraction = float(valid.mean())
            if registration.valid.mean() < 0.05:
                raise CaptureError("the Gray code decoded on almost no pixels: the camera does not see "
                                   "the projection (check exposure, ambient light and aim)")

            reg_stats = {}
            if s.check_registration:
                t = time.perf_counter()
                step = s.check_grid_step
                gx = np.arange(step, model.width - step, step)
                gy = np.arange(step, model.height - step, step)
                xs, ys = np.meshgrid(gx, gy)
                exact = probe.exact_projector_to_camera(bvh, self.projector, model, cam_proj,
                                                        np.stack([xs, ys], -1).astype(float))
                reg_stats = summarize_errors(registration_error_px(cam_xy, valid, gx, gy, exact))
                timings["registration_check_s"] = time.perf_counter() - t
            yield 0.4, "writing references"

            ds.write_projector_images(layout, "ref", ref_images)
            for i, cap in enumerate(ref_caps, start=1):
                ds.write_capture(layout, "raw", "ref", i, cap)
                ds.write_capture(layout, "warp", "ref", i, registration.warp(cap))
            for i, (p, cap) in enumerate(zip(sl_patterns, sl_caps), start=1):
                write_png(layout.image_path(layout.prj_setup_dir("sl"), i), p)
                ds.write_capture(layout, "raw", "sl", i, cap)
            registration.save(os.path.join(layout.setup_dir, "registration.npz"))

            # training and test patterns
            t = time.perf_counter()
            groups = [("train", images[:s.train_count]), ("test", images[s.train_count:])]
            total = len(images)
            done = 0
            for kind, group in groups:
                if len(group) == 0:
                    continue
                ds.write_projector_images(layout, kind, group)
                for start in range(0, len(group), s.chunk):
                    chunk = group[start:start + s.chunk]
                    frames = [emitted_frame(model, im) for im in chunk]
                    for j, linear in enumerate(studio.render(frames), start=start + 1):
                        cap = response.capture(linear, rng)
                        ds.write_capture(layout, "raw", kind, j, cap)
                        ds.write_capture(layout, "warp", kind, j, registration.warp(cap))
                    done += len(chunk)
                    yield 0.4 + 0.58 * done / max(total, 1), f"captures {done}/{total}"
            timings["patterns_s"] = time.perf_counter() - t
            timings["pattern_count"] = total

        meta = {
            "gray_level": s.gray_level,
            "working_size": s.working_size,
            "projector": model.to_dict(),
            "camera": {"resolution": [cam_w, cam_h], "response": response.to_dict(),
                       "lens_mm": self.camera.data.lens, "auto_exposure": self.camera.lapig_camera.auto_exposure},
            "ambient": s.ambient,
            "samples": s.samples,
            "counts": {"train": s.train_count, "test": s.test_count, "sl": len(sl_patterns)},
            "coverage": cover,
            "valid_fraction": valid_fraction,
            "working_valid_fraction": float(registration.valid.mean()),
            "white_clipped_fraction": white_clipped,
            "registration": reg_stats,
            "fingerprint": rig_fingerprint(self.projector, self.camera, self.target),
            "objects": {"projector": self.projector.name, "camera": self.camera.name,
                        "target": self.target.name},
            "blender": bpy.app.version_string,
            "pattern_source": s.pattern_folder or f"generated (seed {s.seed})",
            "timings": {k: round(v, 4) if isinstance(v, float) else v for k, v in timings.items()},
        }
        meta["timings"]["total_s"] = round(time.perf_counter() - t0, 3)
        ds.write_setup_json(layout, meta)
        if final_layout.setup_dir.exists():
            shutil.rmtree(final_layout.setup_dir)
        os.replace(layout.setup_dir, final_layout.setup_dir)
        self.result = {"setup_dir": final_layout.setup_dir, "meta": meta}
        yield 1.0, "capture complete"
