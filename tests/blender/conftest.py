import pytest

bpy = pytest.importorskip("bpy")

from rig_fixtures import small_rig  # noqa: E402


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
