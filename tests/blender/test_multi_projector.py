"""Several projectors on one object in Blender (issue 36): Add Projector, the Cycles capture of two projectors
and its first look, Generate, Export with the MPCDI package, the command line, and the bad inputs.

Tiny on purpose: two 64x48 projectors and an 80x60 camera on the demo statue, four training frames each."""
import json
import os
import subprocess
import sys

import bpy
import numpy as np
import pytest

from test_panels import draw_panels, sentences

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _statue_lit_from_the_front_left(folder, swing_deg=40.0):
    """The demo statue, its projector swung to the camera's left, rigged at the test's tiny sizes."""
    from mathutils import Matrix

    from lapig.lapig_addon.blender import rig
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_core.multi.placement import _rotate_about
    from lapig.lapig_core.optics.placement import look_at

    scene, projector, camera, target = headless.build_demo_setup("statue", "sakura", folder=str(folder),
                                                                 camera_resolution=(80, 60))
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = 64, 48
    rig.add_rig(bpy.context, target, projector, camera)
    centre = rig.object_centre(target)
    position = _rotate_about(np.array(projector.matrix_world.translation), centre, (0, 0, 1), -swing_deg)
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = look_at(position, centre).rotation, position
    projector.matrix_world = Matrix(m.tolist())
    bpy.context.view_layer.update()
    rig.focus_on_object(projector, camera, target)
    s = scene.lapig
    s.train_count, s.test_count, s.working_size = 4, 0, 64
    return scene, projector, camera, target


def _side_of_camera(obj, camera) -> float:
    """> 0: right of the camera's view, < 0: left."""
    right = np.array(camera.matrix_world)[:3, 0]
    return float((np.array(obj.matrix_world.translation) - np.array(camera.matrix_world.translation)) @ right)


@pytest.fixture
def statue(lapig_registered, tmp_path):
    return _statue_lit_from_the_front_left(tmp_path)


@pytest.mark.blender
def test_add_projector_puts_the_second_on_the_other_side_and_the_panel_lists_both(statue, tmp_path):
    from lapig.lapig_addon.blender import scene_state

    scene, projector, camera, target = statue
    one = scene_state.read_rig(scene)
    assert one.projector_count == 1 and one.projectors == (projector.name,)
    assert ("operator", "lapig.add_projector") in draw_panels(bpy.context, [])  # a rig of one: the button alone
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    added = scene_state.rig_projectors(scene)[1]
    assert _side_of_camera(projector, camera) < 0 < _side_of_camera(added, camera)  # front left -> front right
    assert added.lapig_projector.resolution_x == 64 and added.lapig_projector.gamma == projector.lapig_projector.gamma
    forward = -np.array(added.matrix_world)[:3, 2]
    towards = np.array(target.matrix_world.translation) - np.array(added.matrix_world.translation)
    assert forward @ towards / np.linalg.norm(towards) > 0.98  # aimed at the object
    two = scene_state.read_rig(scene)
    assert two.projectors == (projector.name, added.name) and two.projector_sizes == ((64, 48), (64, 48))
    assert two.fingerprint != one.fingerprint  # moving either projector makes the capture stale
    texts = sentences(draw_panels(bpy.context, []))
    assert f"1. {projector.name}: 64x48" in texts and f"2. {added.name}: 64x48" in texts
    # taken off the rig again, the scene reads exactly as a one-projector scene did
    assert bpy.ops.lapig.remove_projector(name=added.name) == {"FINISHED"}
    assert scene_state.read_rig(scene) == one


@pytest.mark.blender
@pytest.mark.torch
def test_two_projectors_capture_first_look_generate_and_export(statue, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.tools.checks.mpcdi_read import read_mpcdi
    from lapig.lapig_core.multi.capture_set import load_multi_capture

    scene, projector, camera, target = statue
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "statue.blend"))
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    names = scene_state.read_rig(scene).projectors
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    state = scene_state.read(scene)
    cs = load_multi_capture(state.capture_dir)
    assert cs.names == names and cs.sizes == ((64, 48), (64, 48)) and cs.captures[0].shape == (4, 60, 80, 3)
    record = json.loads((cs.setup_dir / "models" / "first_look.json").read_text())
    print("coverage single", record["coverage_single"], "joint", record["coverage_joint"])
    assert record["coverage_joint"] >= 0.95 and record["coverage_joint"] >= record["coverage_single"] + 0.1
    assert record["together_rms"] < 0.03  # the two projectors' light adds up as the model says
    assert (cs.setup_dir / "models" / "joint_model.npz").is_file()
    assert state.models_status.startswith("First look (joint classical model of 2 projectors)")
    assert "contrast falls" in state.models_status
    assert dict(state.capture_coverage)[names[0]] == pytest.approx(record["per_projector"][0], abs=1e-3)
    texts = sentences(draw_panels(bpy.context, []))
    assert any(t.startswith(f"1. {names[0]}: 64x48, ") and t.endswith("% of the object") for t in texts)
    assert ("Several projectors use the joint model fitted at the capture: there is nothing to train; Refine on the "
            "Rig corrects what it misses") in texts

    assert bpy.ops.lapig.generate() == {"FINISHED"}
    result = scene_state.read(scene).result_dir
    summary = json.loads(open(os.path.join(result, "result.json")).read())
    assert [p["image"] for p in summary["projectors"]] == ["projector_1.png", "projector_2.png"]
    assert "PSA on their joint reach" in scene.lapig.result_summary
    from lapig.lapig_addon.blender import projector_nodes

    shown = [projector_nodes.projected_image(p.data) for p in scene_state.rig_projectors(scene)]
    assert [tuple(i.size) for i in shown] == [(64, 48), (64, 48)] and shown[0] != shown[1]  # each light its own
    assert summary["psa"]["warm_start_steps"] > 0 and os.path.isfile(os.path.join(result, "projector_1_nopsa.png"))

    # Render Real Capture: both projectors show their image together in Cycles, the camera captures it
    assert bpy.ops.lapig.render_result() == {"FINISHED"}
    from lapig.lapig_core.common.imageio import read_image, write_png
    from lapig.lapig_core.multi.first_look import load_joint_model

    rendered = read_image(os.path.join(result, "rendered.png"))
    write_png("/tmp/lapig_multi_rendered.png", np.concatenate(
        [read_image(os.path.join(result, n + ".png")) for n in ("look", "predicted", "rendered")], axis=1))
    m = json.loads(open(os.path.join(result, "result.json")).read())["metrics"]
    print("rendered", m["rendered_psnr"], "vs predicted", m["rendered_vs_predicted_psnr"], "simulated",
          m["simulated_psnr"])
    assert rendered.shape == (60, 80, 3) and rendered.mean() > 0.03
    reached = load_joint_model(cs.setup_dir).reached
    for k in (0, 1):  # each projector's own region (reached by it alone) is lit
        own = reached[k] & ~reached[1 - k]
        assert own.sum() > 20 and rendered[own].mean() > 0.05, k
    assert np.isfinite(m["rendered_psnr"]) and abs(m["rendered_psnr"] - m["simulated_psnr"]) < 5.0
    assert m["rendered_vs_predicted_psnr"] > 20.0
    texts = sentences(draw_panels(bpy.context, []))  # the result's line says it
    assert any(f"rendered in Cycles {m['rendered_psnr']:.1f} dB against the look" in t for t in texts), texts

    # Light in real units: every projector's light together, each one's share; the dose cap one factor for all
    light = scene.lapig_light
    light.preset, light.lumens, light.ambient_lux, light.category = "NONE", 2000.0, 10.0, "HIGH"
    assert bpy.ops.lapig.light_report() == {"FINISHED"}
    report = json.loads(open(os.path.join(result, "light_report.json")).read())
    print("light", report["projectors_line"], report["look_lux"], report["dose"]["max_lux"])
    assert [p["name"] for p in report["projectors"]] == list(names) and report["frame"] == "camera"
    assert report["lumens"] == pytest.approx(4000) and min(p["share"] for p in report["projectors"]) > 0.1
    from lapig.panels.light_panel import LAPIG_PT_light
    from test_panels import RecordingLayout

    class Layout(RecordingLayout):
        def prop_search(self, data, name, *args, **kwargs):
            self.log.append(("prop", name))

        def _child(self, *args, **kwargs):
            return Layout(self.log)

        row = column = box = split = _child

    log = []
    LAPIG_PT_light.draw(type("P", (), {"layout": Layout(log)})(), bpy.context)
    texts = sentences(log)
    assert any(t.startswith(f"{names[1]}: 2,000 lm, ") for t in texts), texts
    assert bpy.ops.lapig.light_cap() == {"FINISHED"}
    capped = scene_state.read(scene).result_dir
    saved = json.loads(open(os.path.join(capped, "result.json")).read())
    assert capped != result and 0 < saved["dose_cap"]["scale"] < 1
    assert saved["dose_cap"]["max_lux_after"] <= 50.0
    from lapig.lapig_addon.blender.scene_store import scene_seams

    scene_seams(scene).store.record_result(result, summary["summary_line"])  # back to the free look

    # Refine on the rig: both projectors' images projected together in Cycles, corrected jointly
    scene.lapig.refine_steps = 2
    assert bpy.ops.lapig.refine_result() == {"FINISHED"}
    refined = json.loads(open(os.path.join(result, "result.json")).read())
    print("refine", refined["refine"])
    assert [p["image"] for p in refined["projectors"]] == ["projector_1_refined.png", "projector_2_refined.png"]
    assert refined["refine"]["refined_psnr"] >= refined["refine"]["open_loop_psnr"]
    assert "; refined " in scene.lapig.result_summary

    out = tmp_path / "export" / "statue.png"
    out.parent.mkdir()
    assert bpy.ops.lapig.export_image(filepath=str(out)) == {"FINISHED"}
    for k in (1, 2):
        sidecar = json.loads((tmp_path / "export" / f"statue_{k}.json").read_text())
        assert sidecar["image"]["width"] == 64 and sidecar["projector"]["name"] == names[k - 1]
    package = tmp_path / "export" / "statue.mpcdi"
    assert bpy.ops.lapig.export_mpcdi(filepath=str(package)) == {"FINISHED"}
    assert [b.id for b in read_mpcdi(package).buffers] == list(names)
    # a path that cannot be written: one line, the package already there and the result untouched
    before = package.read_bytes()
    with pytest.raises(RuntimeError, match="cannot write the MPCDI package"):
        bpy.ops.lapig.export_mpcdi(filepath=str(tmp_path / "export" / "statue_1.png" / "rig.mpcdi"))
    assert package.read_bytes() == before and scene_state.read(scene).result_dir == result
    # the 'sl' profile through the operator: the rig's real projectors, alphas from the capture's joint model
    shader_lamp = tmp_path / "export" / "statue_sl.mpcdi"
    assert bpy.ops.lapig.export_mpcdi(filepath=str(shader_lamp), profile="sl") == {"FINISHED"}
    sl = read_mpcdi(shader_lamp)
    assert sl.profile == "sl" and [b.id for b in sl.buffers] == list(names)
    # MPCDI 1.0 through the operator (the file browser's MPCDI version): the 1.0 rules hold for both profiles
    from mpcdi_1_0_rules import problems

    for profile in ("2d", "sl"):
        old = tmp_path / "export" / f"statue_{profile}_1_0.mpcdi"
        assert bpy.ops.lapig.export_mpcdi(filepath=str(old), profile=profile, version="1.0") == {"FINISHED"}
        assert problems(old) == [], profile
    for name, ob in zip(names, scene_state.rig_projectors(scene)):
        frame = sl.regions[f"{name} region"].coordinate_frame
        assert frame.position == pytest.approx(tuple(ob.matrix_world.translation), abs=1e-4)
        assert np.isfinite(sl.warp(f"{name} region")).all(axis=-1).any()  # some texels land on the statue


@pytest.mark.blender
def test_a_projector_aimed_away_stops_the_capture_by_name_and_keeps_the_previous_one(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import scene_state

    scene, projector, camera, target = _statue_lit_from_the_front_left(tmp_path, swing_deg=0.0)  # as rigged
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "statue.blend"))
    assert bpy.ops.lapig.capture() == {"FINISHED"}  # one projector: its capture as ever
    before = scene_state.read(scene)
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    astray = scene_state.rig_projectors(scene)[1]
    astray.rotation_euler.rotate_axis("X", np.radians(150))  # at the ceiling
    bpy.context.view_layer.update()
    with pytest.raises(RuntimeError, match=f"projector '{astray.name}' reaches nothing the camera sees"):
        bpy.ops.lapig.capture()
    after = scene_state.read(scene)
    assert after.capture_dir == before.capture_dir and after.capture_fingerprint == before.capture_fingerprint
    assert os.path.isfile(os.path.join(before.capture_dir, "registration.npz"))  # the single capture is whole


@pytest.mark.blender
def test_two_projectors_on_one_display_of_a_real_rig_are_one_line(statue):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state

    scene = statue[0]
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    s = scene.lapig
    s.rig_kind, s.real.display, s.real.camera = "REAL", "1", "0"
    s.extra_projectors[0].display = "1"
    blocker = panel_state.device_blocker(scene_state.read_rig(scene))
    assert blocker == f"Projectors '{s.projector.name}' and '{s.extra_projectors[0].projector.name}' are both on " \
                      f"display '1': give each its own display"
    with pytest.raises(RuntimeError, match="are both on display '1'"):
        bpy.ops.lapig.capture()


def _cli(*args, timeout=600):
    return subprocess.run([sys.executable, "-m", "lapig_addon", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)


@pytest.mark.blender
@pytest.mark.torch
def test_the_command_line_captures_stylizes_and_exports_a_rig_of_two(statue, tmp_path):
    """Projectors of different resolutions too: each keeps its own frame through the joint path."""
    from lapig.lapig_addon.blender import scene_state

    blend = str(tmp_path / "statue.blend")
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    second = scene_state.rig_projectors(statue[0])[1].lapig_projector
    second.resolution_x, second.resolution_y = 48, 36
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    proc = _cli("capture", "--blend", blend, "--save")
    assert proc.returncode == 0, proc.stderr[-2000:]
    captured = json.loads(proc.stdout[proc.stdout.index("{"):])
    assert captured["coverage"]["reached"] > max(captured["coverage"]["per_projector"])
    assert captured["first_look_seconds"] < 10
    proc = _cli("stylize", "--blend", blend, "--prompt", "Make it a stained glass artwork", "--save", "--refine", "1",
                "--render")
    assert proc.returncode == 0, proc.stderr[-2000:]
    stylized = json.loads(proc.stdout[proc.stdout.index("{"):])
    assert stylized["refine"]["iterations"] == 1 and stylized["simulated_psnr_nopsa"] is not None
    # --render: the refined images shown together and captured, after the refinement
    assert np.isfinite(stylized["rendered_psnr"]) and np.isfinite(stylized["rendered_vs_predicted_psnr"])
    assert os.path.isfile(os.path.join(stylized["result"], "rendered.png"))
    out = tmp_path / "out"
    out.mkdir()
    proc = _cli("export", "--blend", blend, "--out", str(out / "look.png"), "--mpcdi", str(out / "rig.mpcdi"))
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert sorted(p.name for p in out.iterdir()) == ["look_1.json", "look_1.png", "look_2.json", "look_2.png",
                                                      "rig.mpcdi"]
    from lapig.lapig_core.common.imageio import read_image
    from lapig.tools.checks.mpcdi_read import read_mpcdi

    assert read_image(out / "look_1.png").shape == (48, 64, 3) and read_image(out / "look_2.png").shape == (36, 48, 3)
    assert [b.resolution for b in read_mpcdi(out / "rig.mpcdi").buffers] == [(64, 48), (48, 36)]
    proc = _cli("export", "--blend", blend, "--out", str(out / "again.png"),
                "--mpcdi", str(out / "look_1.png" / "x.mpcdi"))
    assert proc.returncode == 1 and proc.stderr.strip().startswith("error: cannot write the MPCDI package")
    assert "Traceback" not in proc.stderr and not (out / "again_1.png").exists()
