import shutil

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


def _small_capture(folder, test_count: int):
    """folder/wall.blend, saved after a small capture (working size 64) of the demo panel through the Capture
    operator, with its data folder beside it."""
    scene = small_rig(folder)[0]
    s = scene.lapig
    s.train_count, s.test_count, s.working_size = 6, test_count, 64
    s.finetune_iterations = 4  # quick fine-tune: plumbing, not quality
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "wall.blend"))
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    return folder


def _opened_copy(template, tmp_path):
    """The template's .blend and data folder copied into the test's tmp_path and opened: each test starts
    from the same capture and changes only its own copy (the data folder is recorded relative to the .blend)."""
    shutil.copytree(template, tmp_path, dirs_exist_ok=True)
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "wall.blend"))
    return bpy.context.scene


# the Cycles captures are made once per module (a capture is most of a test's time) and copied for each test
@pytest.fixture(scope="module")
def _captured_template(lapig_registered, tmp_path_factory):
    return _small_capture(tmp_path_factory.mktemp("captured"), test_count=0)


@pytest.fixture(scope="module")
def _captured_with_tests_template(lapig_registered, tmp_path_factory):
    return _small_capture(tmp_path_factory.mktemp("captured_with_tests"), test_count=2)


@pytest.fixture
def captured(_captured_template, tmp_path):
    return _opened_copy(_captured_template, tmp_path)


@pytest.fixture
def captured_with_tests(_captured_with_tests_template, tmp_path):
    """As `captured`, with two held-back test images for the compensator choice."""
    return _opened_copy(_captured_with_tests_template, tmp_path)
