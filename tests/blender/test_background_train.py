"""Train in the background (issue 28) with Cycles: each render of the rendered choice opens and closes the
capture studio within its step; paused between two renders, the capture's folder is free; resumed, every
held-back image is rendered and the choice is the rendered one. The panel shows it with its own Cancel.
(The modal part, Blender's timers and events, needs Blender's UI, which the bpy module has not: the slots
are stepped here as the operators' timers step them.)"""
import os

import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.blender, pytest.mark.torch]


def _running_job():
    from lapig.lapig_addon.services.jobs import Job

    job = Job()
    job.state = "RUNNING"  # the artist's job, as the slots see it
    return job


def test_a_background_train_pauses_between_cycles_renders_and_finishes_the_rendered_choice(captured_with_tests):
    import json

    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.blender.capture_studio import STUDIO_NAME
    from lapig.lapig_addon.blender.modal_runner import SLOTS
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.train.train_job import TrainModelsJob
    from lapig.lapig_core.capture.dataset import resolve_setup
    from lapig.lapig_core.common.locking import FolderLock
    from lapig.lapig_core.photometric import choice
    from test_panels import draw_panels, sentences

    scene = captured_with_tests
    assert SLOTS.background is None  # a Capture run from a script does not chain Train
    job = TrainModelsJob(scene_seams(scene), 4)
    job.poll_timeout = 0.01
    job.device_per_render = True  # as the operator makes it: the studio never outlives a step
    job.check()
    assert SLOTS.start_background(job)
    try:
        while SLOTS.step_background() and not job.message.startswith("measuring"):
            assert STUDIO_NAME not in bpy.data.scenes
        assert job.message.startswith("measuring both compensations on the rig: 1/4")
        assert STUDIO_NAME not in bpy.data.scenes  # the artist's undo or save between two steps never meets it
        assert SLOTS.start_foreground(_running_job()) is None
        while not SLOTS.foreground_may_step():
            pass
        assert job.paused and STUDIO_NAME not in bpy.data.scenes  # the studio closed between two renders
        FolderLock(resolve_setup(scene_state.read(scene).capture_dir).root, "LAPIG generate").acquire().release()
        log = draw_panels(bpy.context, [])
        assert ("operator", "lapig.cancel_background_train") in log
        assert any(t.startswith("Training in the background: paused") for t in sentences(log))
        SLOTS.end_foreground(SLOTS.foreground)
        while SLOTS.step_background():
            assert STUDIO_NAME not in bpy.data.scenes
        assert job.state == "DONE", job.message
        saved = json.load(open(os.path.join(scene_state.read(scene).capture_dir, "models", choice.CHOICE_FILE)))
        assert saved["judge"] == choice.RENDERED_JUDGE and saved["validation_pairs"] == 2
        assert "in Cycles captures of 2 held-back images" in scene_state.read(scene).models_status
    finally:
        SLOTS.cancel_background()
        SLOTS.end_background(job, None)
        SLOTS.foreground = None


def test_the_panels_cancel_stops_the_background_train(captured_with_tests):
    from lapig.lapig_addon.blender.modal_runner import SLOTS
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.train.train_job import TrainModelsJob

    scene = captured_with_tests
    # what Capture's on_done calls after a capture in the UI: without Blender's UI it starts nothing
    assert "RUNNING_MODAL" not in bpy.ops.lapig.train_background("INVOKE_DEFAULT") and SLOTS.background is None
    job = TrainModelsJob(scene_seams(scene), 4)
    job.poll_timeout = 0.01
    job.check()
    SLOTS.start_background(job)
    SLOTS.step_background()
    assert bpy.ops.lapig.cancel_background_train() == {"FINISHED"}
    assert job.state == "CANCELLED" and not SLOTS.background_running()
    SLOTS.end_background(job, None)
