"""The lumens -> watts conversion checked by a Cycles render: a white panel's illuminance at the nine
ANSI points is lumens / image area; a region that is not there is refused in one line."""

from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.blender


def _panel_and_projector(albedo=0.8):
    from lapig.lapig_addon.blender import demo_scene, rig

    demo_scene.new_empty_scene()
    bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, 0))
    panel = bpy.context.active_object
    material = bpy.data.materials.new("white")
    tree = material.node_tree
    for node in [n for n in tree.nodes if n.bl_idname != "ShaderNodeOutputMaterial"]:
        tree.nodes.remove(node)
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (albedo, albedo, albedo, 1)
    tree.links.new(diffuse.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    panel.data.materials.append(material)
    projector = rig.create_projector(bpy.context.scene)
    projector.location = (0, 0, 1.5)
    bpy.context.view_layer.update()
    return panel, projector


def _train_in_the_background(slots, hold=None):
    """A stand-in for Train, started in the background job slot: it reports (a pause point) until cancelled;
    hold(job): the lock it takes (None: none)."""
    import time

    from lapig.lapig_addon.services.jobs import WorkerJob

    class Training(WorkerJob):
        title = "LAPIG training"

        def hold(self, inputs):
            return hold(self) if hold is not None else super().hold(inputs)

        def work(self, inputs, report, cancel_event):
            while not cancel_event.is_set():
                report(0.5, "training")
                time.sleep(0.01)

    train = Training()
    train.poll_timeout = 0
    assert slots.start_background(train)
    slots.step_background()
    return train


@pytest.mark.parametrize("frame,size", [((800, 600), (48, 36)), ((1280, 800), (48, 30))])
def test_rendered_lux_on_a_white_panel_is_lumens_per_area(lapig_registered, frame, size):
    from lapig.lapig_addon.blender import light_render, scene_state
    from lapig.lapig_core.photometry import units

    panel, projector = _panel_and_projector()
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = frame
    model = scene_state.projector_model(projector)
    projector.lapig_projector.brightness = units.lumens_to_watts(1000, model)
    w, h = size
    maps = light_render.projector_light_maps(bpy.context.scene, projector, panel, w, h)
    lux = units.lux_from_radiance(maps.white_radiance, 0.8)
    nine = [lux[int(fy * h), int(fx * w)] for fy in (1 / 6, 1 / 2, 5 / 6) for fx in (1 / 6, 1 / 2, 5 / 6)]
    predicted = 1000 / units.image_area_m2(model, 1.5)
    assert abs(np.mean(nine) / predicted - 1) < 0.02
    assert np.allclose(maps.white_lux, lux, rtol=1e-3)  # the Diffuse Direct pass says the same
    assert maps.on_object.all() and len(bpy.data.scenes) == 1  # the light studio is gone
    with pytest.raises(light_render.LightRenderError, match="does not have the projector's"):
        light_render.projector_light_maps(bpy.context.scene, projector, panel, w, w)


def test_an_unknown_region_material_is_refused(lapig_registered):
    from lapig.lapig_addon.blender import light_render

    panel, projector = _panel_and_projector()
    with pytest.raises(light_render.LightRenderError, match="no material 'velvet'.*its materials: white"):
        light_render.projector_light_maps(bpy.context.scene, projector, panel, 16, 12, region_material="velvet")
    assert len(bpy.data.scenes) == 1


def test_a_vertex_group_marks_its_faces_and_an_empty_one_is_refused(lapig_registered):
    from lapig.lapig_addon.blender import light_render

    panel, projector = _panel_and_projector()
    bpy.context.view_layer.objects.active = panel
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.subdivide(number_cuts=3)
    bpy.ops.object.mode_set(mode="OBJECT")
    left = [v.index for v in panel.data.vertices if v.co.x <= 0.0]
    group = panel.vertex_groups.new(name="paper")
    group.add(left, 1.0, "REPLACE")
    maps = light_render.projector_light_maps(bpy.context.scene, projector, panel, 32, 24, region_group="paper")
    assert maps.on_object.all()
    share = maps.region.mean()
    assert 0.4 < share < 0.6 and maps.region[:, :12].all() and not maps.region[:, -12:].any()
    panel.vertex_groups.new(name="empty")
    with pytest.raises(light_render.LightRenderError, match="'empty' has no faces"):
        light_render.projector_light_maps(bpy.context.scene, projector, panel, 16, 12, region_group="empty")
    with pytest.raises(light_render.LightRenderError, match="no vertex group 'velvet'.*paper, empty"):
        light_render.projector_light_maps(bpy.context.scene, projector, panel, 16, 12, region_group="velvet")
    assert len(bpy.data.scenes) == 1 and len(bpy.data.meshes) == 1  # the parts are gone


def test_the_light_panel_draws_the_plan_and_says_what_is_wrong(lapig_registered, small_setup):
    from test_panels import RecordingLayout, sentences

    from lapig.panels.light_panel import LAPIG_PT_light

    class Layout(RecordingLayout):
        def prop_search(self, data, name, search_data, search_name, **kwargs):
            assert name in data.bl_rna.properties and hasattr(search_data, search_name)
            self.log.append(("prop", name))

        def _child(self, *args, **kwargs):
            return Layout(self.log)

        row = column = box = split = _child

    s = bpy.context.scene.lapig_light
    s.preset, s.category = "optoma-ml500", "HIGH"
    log = []
    LAPIG_PT_light.draw(type("P", (), {"layout": Layout(log)})(), bpy.context)
    assert ("operator", "lapig.light_report") in log and ("operator", "lapig.light_cap") in log
    assert ("operator", "lapig.light_apply") in log
    for name in ("preset", "ambient_lux", "category", "hours_per_day", "days_per_year", "region_material",
                 "region_group"):
        assert ("prop", name) in log
    s.preset, s.lumens = "NONE", 0.0
    log = []
    LAPIG_PT_light.draw(type("P", (), {"layout": Layout(log)})(), bpy.context)
    assert any("brightness in lumens" in t for t in sentences(log))


def test_the_maps_see_the_real_surface_while_the_object_shows_a_preview(lapig_registered):
    from lapig.lapig_addon.blender import light_render, preview

    panel, projector = _panel_and_projector()
    plain = light_render.projector_light_maps(bpy.context.scene, projector, panel, 16, 12)
    preview.enable_preview(panel, projector, projector.data.node_tree.nodes["LAPIG projected image"].image,
                           appearance=True)  # an unlit copy of the material, as the Lux preview has
    seen = light_render.projector_light_maps(bpy.context.scene, projector, panel, 16, 12,
                                             region_material="white")
    assert np.allclose(seen.white_lux, plain.white_lux) and np.allclose(seen.albedo, 0.8, atol=1e-3)
    assert seen.region.all() and preview.is_previewing(panel)  # the preview is back
    preview.disable_preview(panel)


def test_light_report_previews_and_export_carry_the_figures(small_setup, tmp_path):
    import json

    from test_existing_result import write_fake_result

    scene, projector, camera, target = small_setup
    scene.lapig.result_dir = write_fake_result(tmp_path / "result")
    with pytest.raises(RuntimeError, match="press Light Report"):
        bpy.ops.lapig.preview_mode(mode="LUX")
    s = scene.lapig_light
    s.preset, s.ambient_lux, s.category = "panasonic-pt-lb90", 100.0, "MODERATE"
    assert bpy.ops.lapig.light_report() == {"FINISHED"}
    assert scene.lapig.preview_mode == "LUX"
    assert bpy.ops.lapig.preview_mode(mode="CONTRAST") == {"FINISHED"}
    assert bpy.ops.lapig.preview_mode(mode="ORIGINAL") == {"FINISHED"}
    path = tmp_path / "look.png"
    assert bpy.ops.lapig.export_image(filepath=str(path)) == {"FINISHED"}
    light = json.loads((tmp_path / "look.json").read_text())["light"]
    assert light["lumens"] == 3000 and light["preset"]["id"] == "panasonic-pt-lb90"
    assert light["dose"]["limit_lux"] == 200 and light["total_lux"]["max"] > 0
    table = (tmp_path / "look_projectors.csv").read_text().splitlines()
    assert table[0].startswith("Name,Manufacturer,Model") and ",Panasonic,PT-LB90,160,120,3000," in table[1]
    # Use This Projector: the model's frame, the throw nearest the rig's (1.5 is in 1.44-1.73), its power
    assert bpy.ops.lapig.light_apply() == {"FINISHED"}
    p = projector.lapig_projector
    assert (p.resolution_x, p.resolution_y) == (1024, 768) and p.throw_ratio == pytest.approx(1.5)
    assert projector.data.energy == pytest.approx(p.brightness) and p.black_level == pytest.approx(1 / 500)


def test_limit_look_to_the_dose_pauses_the_background_train_and_holds_the_captures_folder(small_setup, tmp_path,
                                                                                           monkeypatch):
    """A foreground job like Refine: the background Train pauses (and lets go of the capture's folder), the cap
    holds that folder while it renders and writes, and Train goes on afterwards."""
    import time

    from test_existing_result import write_fake_result

    from lapig.lapig_addon.blender import light_render, scene_state
    from lapig.lapig_addon.blender.modal_runner import SLOTS
    from lapig.lapig_addon.services.light import light_report
    from lapig.lapig_core.common.locking import LOCK_FILE, FolderLock, holder_of

    scene, projector = small_setup[:2]
    root = tmp_path / "data"
    (root / "setups" / "panel").mkdir(parents=True)  # the scene's capture, as the data set lays it out
    scene_state.record_capture(scene, str(root / "setups" / "panel"), scene_state.read_rig(scene).fingerprint)
    p = projector.lapig_projector
    scene.lapig.result_dir = write_fake_result(tmp_path / "result", p.resolution_x, p.resolution_y)
    s = scene.lapig_light
    s.preset, s.ambient_lux, s.category = "panasonic-pt-lb90", 10.0, "HIGH"

    train = _train_in_the_background(SLOTS, lambda job: FolderLock(root, job.title).acquire())
    while not (root / LOCK_FILE).exists():
        time.sleep(0.01)
    seen = []
    render = light_render.LightStudio._render

    def render_and_see(studio, *args, **kwargs):  # each Cycles render
        seen.append((train.paused, holder_of(root / LOCK_FILE)))
        return render(studio, *args, **kwargs)

    monkeypatch.setattr(light_render.LightStudio, "_render", render_and_see)
    try:
        assert bpy.ops.lapig.light_cap() == {"FINISHED"}
        # the projector's light and the room's at the report's size, the projector's at its native size; the new
        # look's report is made on those room maps
        assert len(seen) == 3 and all(paused for paused, _ in seen), "the background Train was not paused"
        for _, holder in seen:  # the cap's renders: the cap holds the capture's folder
            assert holder.startswith("LAPIG limit to the dose"), holder
        assert light_report.read_report(scene.lapig.result_dir)["dose"]["limit_lux"] == 50
        assert scene.lapig.result_dir.endswith("_dose_cap") and not train.pause_requested  # Train goes on
    finally:
        SLOTS.cancel_background()
        SLOTS.end_background(train, None)


RECORDED_REPORT = Path(__file__).with_name("light_report_before_job.json")  # the synchronous path's report


def _report_scene(small_setup, tmp_path):
    """The small rig with a look at the projector's native size, a Panasonic in a 10 lux room and the object
    marked 'high': the light report renders the projector's light and the room's (two Cycles renders)."""
    from test_existing_result import write_fake_result

    scene, projector = small_setup[:2]
    p = projector.lapig_projector
    scene.lapig.result_dir = write_fake_result(tmp_path / "result", p.resolution_x, p.resolution_y)
    s = scene.lapig_light
    s.preset, s.ambient_lux, s.category = "panasonic-pt-lb90", 10.0, "HIGH"
    return scene, scene.lapig.result_dir


def _comparable(report: dict) -> dict:
    """The report without the paths of this run's folders."""
    return {k: v for k, v in report.items() if k not in ("result", "report_file", "maps")}


def _same_numbers(got, want, exact: bool, where="report"):
    """Equal where the recording's Blender renders (Cycles is deterministic there); within 2% elsewhere."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and sorted(got) == sorted(want), where
        for key in want:
            _same_numbers(got[key], want[key], exact, f"{where}.{key}")
    elif isinstance(want, list):
        assert isinstance(got, (list, tuple)) and len(got) == len(want), where
        for i, (g, w) in enumerate(zip(got, want)):
            _same_numbers(g, w, exact, f"{where}[{i}]")
    elif isinstance(want, (int, float)) and not isinstance(want, bool):
        assert got == (want if exact else pytest.approx(want, rel=0.02, abs=0.02)), where
    elif exact or not isinstance(want, str):
        assert got == want, where


def test_light_report_is_a_job_that_pauses_the_background_train_and_reports_as_before(small_setup, tmp_path,
                                                                                      monkeypatch, capsys):
    """Issue 35: Light Report runs as a foreground job: the background Train pauses before its first render and
    goes on afterwards, the Cycles renders run on the main thread (one a step), and the report is the one the
    synchronous path wrote on the same scene (recorded in light_report_before_job.json), as is the `report`
    command's, which runs the same job."""
    import json
    import threading
    import time
    from argparse import Namespace

    from lapig.lapig_addon.blender import light_render
    from lapig.lapig_addon.blender.modal_runner import SLOTS
    from lapig.lapig_addon.cli import report_command
    from lapig.lapig_addon.services.light import light_report

    scene, folder = _report_scene(small_setup, tmp_path)

    train = _train_in_the_background(SLOTS)
    seen = []  # at each Cycles render: whether Train was paused, and the thread
    render = light_render.LightStudio._render

    def render_and_see(studio, *args, **kwargs):
        seen.append((train.paused, threading.current_thread() is threading.main_thread()))
        return render(studio, *args, **kwargs)

    monkeypatch.setattr(light_render.LightStudio, "_render", render_and_see)
    try:
        assert bpy.ops.lapig.light_report() == {"FINISHED"}
        assert seen == [(True, True), (True, True)], seen  # the projector's light and the room's, Train paused
        assert not train.pause_requested and not train.finished  # Train goes on
    finally:
        SLOTS.cancel_background()
        SLOTS.end_background(train, None)
    assert scene.lapig.preview_mode == "LUX"
    recorded = json.loads(RECORDED_REPORT.read_text())
    exact = bpy.app.version_string == recorded["blender"]
    report = light_report.read_report(folder)
    _same_numbers(_comparable(report), recorded["report"], exact)

    # the `report` command runs the same job: the same figures, printed
    args = Namespace(blend=None, save=False, result=folder, preset="panasonic-pt-lb90", list_presets=False,
                     lumens=0.0, contrast=0.0, ambient_lux=10.0, lamp_direction=None, category="high",
                     limit_lux=50.0, hours_per_day=8.0, days_per_year=300.0, region_material="", region_group="",
                     map_width=160, maps=str(tmp_path / "maps"), cap_out=None, cap_result=False, psnr=False,
                     apply=False)
    capsys.readouterr()
    assert report_command.cmd_report(args) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    _same_numbers(_comparable(printed), recorded["report"], exact)
    assert sorted(p.name for p in (tmp_path / "maps").iterdir()) == ["light_contrast.png", "light_luminance.png",
                                                                      "light_lux.png"]


def test_the_light_panel_shows_the_reports_progress_and_says_why_its_buttons_are_off(lapig_registered, small_setup):
    """While a foreground job runs, the Light Report's progress line shows (Esc cancels), and its button is off: the
    job slots hold one foreground job and queue none, which its tooltip says."""
    from test_panels import RecordingLayout

    from lapig.lapig_addon.blender.modal_runner import SLOTS
    from lapig.lapig_addon.services.jobs import Job
    from lapig.lapig_addon.services.light.light_report_job import LightReportJob
    from lapig.operators.light_ops import LAPIG_OT_light_report
    from lapig.panels.light_panel import LAPIG_PT_light

    class Layout(RecordingLayout):
        def prop_search(self, *args, **kwargs):
            pass

        def operator(self, idname, **kwargs):
            self.log.append(("enabled", idname, self.enabled))
            return super().operator(idname, **kwargs)

        def _child(self, *args, **kwargs):
            return Layout(self.log)

        row = column = box = split = _child

    def drawn():
        log = []
        LAPIG_PT_light.draw(type("P", (), {"layout": Layout(log)})(), bpy.context)
        return log

    bpy.context.scene.lapig_light.preset = "optoma-ml500"
    assert ("enabled", "lapig.light_report", True) in drawn()
    tip = LAPIG_OT_light_report.description(bpy.context, None)
    assert tip.startswith("Render the look's light in lux") and "queue" not in tip
    job = Job()
    job.title, job.state, job.progress, job.message = LightReportJob.title, "RUNNING", 0.4, "rendering the room's light"
    assert SLOTS.start_foreground(job) is None
    try:
        log = drawn()
        assert ("progress", "rendering the room's light (Esc to cancel)") in log
        assert ("enabled", "lapig.light_report", False) in log
        tip = LAPIG_OT_light_report.description(bpy.context, None)
        assert tip.startswith("Render the look's light in lux")
        assert "Off while LAPIG light report runs" in tip and "does not queue another" in tip
    finally:
        SLOTS.end_foreground(job)
