"""Refine on the rig in Cycles: a small corner captured in the Realistic transport (bounce light the per-pixel
model cannot hold), a weak open-loop image refined through the Cycles device factory, the same loop the panel
and `stylize --refine` run."""
import cv2
import numpy as np
import pytest

# torch: the refine job's module imports the pipeline jobs, which import Train's choice
pytestmark = [pytest.mark.blender, pytest.mark.torch]


def test_refinement_through_cycles_corrects_the_open_loop_image(lapig_registered, tmp_path):
    import bpy

    from lapig.lapig_addon.blender import rig, scene_state
    from lapig.lapig_addon.blender.cycles_factory import CyclesDeviceFactory
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_addon.services.refine.refine_job import refine_rounds
    from lapig.lapig_core.common.steps import run_to_end
    from lapig.lapig_core.capture.dataset import load_capture_set
    from lapig.lapig_core.photometric.box_solve import box_compensate
    from lapig.lapig_core.photometric.classical import ClassicalModel
    from lapig.lapig_core.photometric.targets import desired_targets, reachable_mask
    from lapig.lapig_core.refine.loop import Refinement, RefineSettings

    scene, projector, camera, target = headless.build_demo_setup("corner", "wood", folder=str(tmp_path),
                                                                 camera_resolution=(160, 120))
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = (160, 120)
    rig.add_rig(bpy.context, target, projector, camera)
    projector.lapig_projector.transport_mode = "REALISTIC"
    settings = scene_state.capture_settings(scene, out_dir=str(tmp_path / "data"), setup_name="corner",
                                            train_count=12, test_count=2, working_size=64)
    setup_dir = headless.run_capture(scene, settings)["setup_dir"]
    cs = load_capture_set(setup_dir)
    model = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    valid = reachable_mask(cs.cam_black, cs.cam_white) & cs.projector_valid
    targets = desired_targets(cs.prj_test[:1], cs.cam_black, cs.cam_white, valid)
    weak = box_compensate(model, targets) * 0.8 ** (1 / model.gamma_p)  # a model 20 % off in its light
    devices = CyclesDeviceFactory(scene, projector, camera, target)
    refinement = Refinement(model, targets, cs.cam_black, cs.cam_white, valid, weak, RefineSettings(iterations=3))
    run_to_end(refine_rounds(devices, setup_dir, refinement))
    rec = refinement.record
    assert rec.refined_psnr > rec.open_loop_psnr + 3, rec.to_dict()
    assert np.isfinite(rec.noise_floor_psnr) and rec.noise_floor_psnr > rec.open_loop_psnr
    assert rec.captures >= 2 + rec.iterations  # the noise pair, then a round per step
    assert 0 <= refinement.images.min() and refinement.images.max() <= 1
    # the native output (the projector's 160x120, twice the working frame) refined itself
    native = cv2.resize(weak[0], (160, 120), interpolation=cv2.INTER_LINEAR)
    on_native = Refinement(model, targets, cs.cam_black, cs.cam_white, valid, None, RefineSettings(iterations=3),
                           native_start=native)
    run_to_end(refine_rounds(devices, setup_dir, on_native))
    assert on_native.images.shape == (1, 120, 160, 3)
    assert on_native.record.refined_psnr > on_native.record.open_loop_psnr + 3, on_native.record.to_dict()
