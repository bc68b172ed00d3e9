import pytest

bpy = pytest.importorskip("bpy")

from rig_fixtures import small_rig  # noqa: E402


@pytest.fixture(autouse=True)
def no_job_outlives_its_test():
    """A cancelled job's worker finishes its current step in the background (the UI does not wait for it);
    the next test's Cycles render must not run beside it (numpy's threads beside a render crashed once)."""
    yield
    import threading

    from lapig.lapig_addon.services.jobs import THREAD_PREFIX

    for thread in threading.enumerate():
        if thread.name.startswith(THREAD_PREFIX):
            thread.join(timeout=300)


@pytest.fixture(scope="session")
def lapig_registered():
    from lapig.lapig_addon.blender import addon

    if not addon.is_registered():
        addon.register()
    yield
    addon.unregister()


@pytest.fixture
def small_setup(lapig_registered, tmp_path):
    return small_rig(tmp_path)


def _small_capture(small_setup, tmp_path, test_count: int):
    """A saved .blend with a small capture (working size 64) of the demo panel, through the Capture operator."""
    scene = small_setup[0]
    s = scene.lapig
    s.train_count, s.test_count, s.working_size = 6, test_count, 64
    s.finetune_iterations = 4  # quick fine-tune: plumbing, not quality
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "wall.blend"))
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    return bpy.context.scene


@pytest.fixture
def captured(small_setup, tmp_path):
    return _small_capture(small_setup, tmp_path, test_count=0)


@pytest.fixture
def captured_with_tests(small_setup, tmp_path):
    """As `captured`, with two held-back test images for the compensator choice."""
    return _small_capture(small_setup, tmp_path, test_count=2)
