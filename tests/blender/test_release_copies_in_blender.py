"""What release 0.1.0 wrote opens and runs with today's code (issue 51 item 3): its .blend files (one projector,
two projectors), their captures and results, saved in tests/data/release_0_1_0 by tools/release_copies.py.

Nothing in them needed migrating: the formats are unchanged, and these tests say so. Export of the saved result
gives the same pixels as the release exported, the .blend's rig, capture and result are read back, and a new
look is made on the saved capture.
"""
import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

ROOT = pathlib.Path(__file__).resolve().parents[2]
RELEASE = ROOT / "tests" / "data" / "release_0_1_0"
MADE = json.loads((RELEASE / "MADE_BY.json").read_text(encoding="utf-8"))

pytestmark = [pytest.mark.blender, pytest.mark.torch]


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "lapig_addon", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=900)


def _copy(name, tmp_path):
    """The saved copy in tmp_path (tests never write into the checkout): its .blend and data folder."""
    shutil.copytree(RELEASE / name, tmp_path / name)
    return tmp_path / name


def _pixels(path):
    from lapig.lapig_core.common.imageio import read_image

    return read_image(path)


def _sidecar(path):
    side = json.loads(pathlib.Path(path).read_text(encoding="utf-8"))
    for key in ("created", "software", "software_blender", "image"):  # when and by what it was written
        side.pop(key, None)
    return side


def test_the_releases_blend_of_one_projector_opens_with_its_capture_and_result(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state

    folder = _copy("one", tmp_path)
    bpy.ops.wm.open_mainfile(filepath=str(folder / "wall.blend"))
    state = scene_state.read(bpy.context.scene)
    assert state.rig.projector_count == 1 and state.rig.projector_size == (64, 48)
    assert os.path.samefile(state.capture_dir, tmp_path / MADE["copies"]["one"]["capture"])
    assert os.path.samefile(state.result_dir, tmp_path / MADE["copies"]["one"]["result"])
    assert panel_state.capture_status(state).state == "DONE"
    assert not panel_state.preview_blocker(state, "TARGET")


def test_the_releases_blend_of_two_projectors_opens_with_both(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import scene_state

    folder = _copy("two", tmp_path)
    bpy.ops.wm.open_mainfile(filepath=str(folder / "wall.blend"))
    state = scene_state.read(bpy.context.scene)
    assert state.rig.projector_count == 2 and state.rig.projector_sizes == ((64, 48), (64, 48))
    assert os.path.samefile(state.capture_dir, tmp_path / MADE["copies"]["two"]["capture"])
    assert os.path.samefile(state.result_dir, tmp_path / MADE["copies"]["two"]["result"])


@pytest.mark.parametrize("name", ["one", "two"])
def test_todays_export_of_the_releases_result_is_the_releases_export(name, tmp_path):
    folder = _copy(name, tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    extra = ["--mpcdi", str(out / "rig.mpcdi")] if name == "two" else []
    proc = _cli("export", "--blend", str(folder / "wall.blend"), "--out", str(out / "projector.png"), *extra)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert sorted(p.name for p in out.iterdir()) == MADE["copies"][name]["exported"]
    for png in sorted(out.glob("*.png")):
        np.testing.assert_array_equal(_pixels(png), _pixels(folder / "export" / png.name))
        assert _sidecar(png.with_suffix(".json")) == _sidecar(folder / "export" / png.with_suffix(".json").name)
    if extra:  # the package: the same files, and the same XML but for the date it was written
        import re
        import zipfile

        from lapig.tools.checks.mpcdi_read import read_mpcdi

        assert [b.resolution for b in read_mpcdi(out / "rig.mpcdi").buffers] == [(64, 48)] * 2
        with zipfile.ZipFile(out / "rig.mpcdi") as ours, zipfile.ZipFile(folder / "export" / "rig.mpcdi") as theirs:
            assert sorted(ours.namelist()) == sorted(theirs.namelist())
            for member in ours.namelist():
                a, b = ours.read(member), theirs.read(member)
                if member.endswith(".xml"):
                    a, b = (re.sub(rb'date="[^"]*"', b"", x) for x in (a, b))
                assert a == b, member


@pytest.mark.parametrize("name", ["one", "two"])
def test_a_new_look_is_made_on_the_releases_capture(name, tmp_path):
    folder = _copy(name, tmp_path)
    proc = _cli("stylize", "--blend", str(folder / "wall.blend"), "--prompt", "Make it a charcoal sketch", "--no-psa",
                "--save")
    assert proc.returncode == 0, proc.stderr[-2000:]
    made = json.loads(proc.stdout[proc.stdout.index("{"):])
    result = pathlib.Path(made["result"])
    assert result.parent == (tmp_path / MADE["copies"][name]["result"]).parent  # beside the release's own result
    images = ["projector.png"] if name == "one" else ["projector_1.png", "projector_2.png"]
    for image in images:
        assert _pixels(result / image).std() > 0.01  # a look, not a blank frame
