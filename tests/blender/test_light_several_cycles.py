"""Light in real units from several projectors (issue 36), in Cycles at tiny sizes: each projector's light over
the rig camera's pixels, added; two identical stacked projectors give twice the lux of one; the Light Report of
a rig of two names each one's share."""
import json
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from test_multi_projector import _statue_lit_from_the_front_left  # noqa: E402

pytestmark = pytest.mark.blender


def _mean_lux(scene, plan):
    from lapig.lapig_addon.blender.light_plan_run import JointSceneLight
    from lapig.lapig_core.common.steps import run_to_end
    from lapig.lapig_core.photometry.light_passes import sum_projector_maps

    light = JointSceneLight(scene, plan, width=40)  # one projector too: over the camera's pixels
    maps, _ = run_to_end(light.steps())
    total = sum_projector_maps(maps)
    return float(total.white_lux[total.on_object].mean()), maps, light


def test_two_stacked_projectors_give_twice_the_lux_of_one(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.light.light_report import LightPlan

    scene, projector, camera, target = _statue_lit_from_the_front_left(tmp_path, swing_deg=0.0)
    plan = LightPlan(lumens=2000)
    one, maps1, light1 = _mean_lux(scene, plan)
    assert len(maps1) == 1 and maps1[0].white_lux.shape == (30, 40) and one > 1.0
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    added = scene_state.rig_projectors(scene)[1]
    added.matrix_world = projector.matrix_world.copy()  # stacked: the same pose, the same settings
    bpy.context.view_layer.update()
    two, maps2, light2 = _mean_lux(scene, plan)
    print("one projector", one, "lux; two stacked", two, "lux; ratio", two / one)
    assert light2.lumens == pytest.approx([2000, 2000])
    assert abs(two / one - 2.0) < 0.2  # within 10 %
    assert len(bpy.data.scenes) == 1  # the studios are gone


def test_the_light_report_of_two_projectors_names_each_ones_share(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import light_plan_run
    from lapig.lapig_addon.services.light.light_report import LightPlan
    from lapig.lapig_core.common.imageio import read_image, write_png
    from lapig.lapig_core.photometry import dose

    scene, projector, camera, target = _statue_lit_from_the_front_left(tmp_path)
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}  # the other side
    plan = LightPlan(lumens=2000, ambient_lux=10, limit=dose.ConservationLimit("high"))
    maps_dir = str(tmp_path / "maps")
    report = light_plan_run.report_job(scene, plan, None, width=40, maps_dir=maps_dir).run_to_completion()
    print(json.dumps(report["projectors"]), report["white_lux"], report["dose"]["max_lux"],
          report["dose_cap_scale"])
    assert report["frame"] == "camera" and report["lumens"] == pytest.approx(4000)
    shares = [p["share"] for p in report["projectors"]]
    assert sum(shares) == pytest.approx(1.0, abs=1e-3) and min(shares) > 0.2  # both light the statue
    assert report["projectors_line"].count("of the light") == 2
    lux = read_image(os.path.join(maps_dir, "light_lux.png"))
    assert lux.shape[:2] == (30, 40)
    write_png("/tmp/lapig_lux_two_projectors.png", np.repeat(np.repeat(lux, 8, 0), 8, 1))
    assert 0 < report["dose_cap_scale"] <= 1.0


def test_the_report_command_adds_every_projectors_light(lapig_registered, tmp_path):
    from test_multi_projector import _cli

    scene, projector, camera, target = _statue_lit_from_the_front_left(tmp_path)
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    blend = str(tmp_path / "two.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    proc = _cli("report", "--blend", blend, "--lumens", "1500", "--ambient-lux", "5", "--map-width", "40",
                "--maps", str(tmp_path / "maps"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(proc.stdout[proc.stdout.index("{"):])
    assert report["frame"] == "camera" and report["lumens"] == pytest.approx(3000)
    assert [p["lumens"] for p in report["projectors"]] == [1500, 1500]
    assert (tmp_path / "maps" / "light_lux.png").is_file()
    proc = _cli("report", "--blend", blend, "--lumens", "1500", "--category", "high", "--cap-out",
                str(tmp_path / "cap.png"))
    assert proc.returncode == 1 and "--cap-out and --psnr work with one projector" in proc.stderr
