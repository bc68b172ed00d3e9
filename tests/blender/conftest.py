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
