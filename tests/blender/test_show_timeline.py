"""The show on Blender's timeline (issue 38): the list's markers and range, the baked frames wired into the
projector light as an image sequence relative to the .blend, and a render of the animation in a fresh bpy
process with no add-on (what a render farm does), also after the .blend and its data folder moved together."""
import os
import shutil
import subprocess
import sys
import textwrap

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

COLOURS = [(0.95, 0.1, 0.1), (0.1, 0.9, 0.15), (0.1, 0.2, 0.95)]
RENDER = (64, 48)

# run by a fresh interpreter: bpy only, no add-on, the repository nowhere on sys.path
RENDER_SCRIPT = textwrap.dedent("""
    import sys
    import bpy
    blend, out = sys.argv[1], sys.argv[2]
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    for frame in (1, 3):
        scene.frame_set(frame)
        scene.render.filepath = f"{out}/frame_{frame}.png"
        bpy.ops.render.render(write_still=True)
    loaded = [name for name in sys.modules if name == "lapig" or name.startswith(("lapig.", "lapig_"))]
    print("ADDON-FREE", not loaded and not hasattr(bpy.types.Scene, "lapig"))
""")


def _results(scene_data_root):
    """Three results of the scene's projector, each one flat colour (plain numpy), in the .blend's data folder."""
    from lapig.lapig_core.export.result_files import write_result

    folders = []
    for i, colour in enumerate(COLOURS):
        image = np.broadcast_to(np.float32(colour), (48, 64, 3)).copy()
        folders.append(str(write_result(os.path.join(scene_data_root, "results", f"look{i}"), {"projector": image},
                                        {"prompt": f"look {i}", "backend": "styletransfer", "seed": i})))
    return folders


@pytest.fixture
def show_scene(small_setup, tmp_path):
    """The small rig saved as wall.blend with a show of three one-frame-long looks (no transitions) at 10 fps."""
    from lapig.lapig_addon.blender import scene_state, storage

    scene, projector, camera, target = small_setup
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = 64, 48
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "wall.blend"))
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 10, 1.0
    scene.frame_start = 1
    for i, folder in enumerate(_results(storage.data_root()[0])):
        scene_state.add_show_look(scene, folder, name=f"Look {'ABC'[i]}", hold_s=0.1, transition_s=0.0)
    return scene


def test_the_show_is_on_the_timeline_as_markers_rewritten_when_the_list_changes(show_scene):
    from lapig.lapig_addon.blender import scene_state

    scene = show_scene
    scene.timeline_markers.new("artist's cue", frame=2)
    marks = lambda: sorted((m.frame, m.name) for m in scene.timeline_markers)  # noqa: E731
    assert marks() == [(1, "Look A"), (2, "Look B"), (2, "artist's cue"), (3, "Look C")]
    assert scene.frame_end == 3
    scene_state.set_show_look(scene, 0, hold_s=0.5, transition="dissolve", transition_s=0.3)
    assert marks() == [(1, "Look A"), (2, "artist's cue"), (6, "dissolve 0.3s to Look B"), (9, "Look B"),
                       (10, "Look C")]
    assert scene.frame_end == 10
    assert scene_state.move_show_look(scene, 2, -1) == 1
    assert [n for _, n in marks() if n.startswith("Look")] == ["Look A", "Look C", "Look B"]
    assert scene_state.remove_show_look(scene, 0) and scene.lapig.show_index == 0
    assert marks() == [(1, "Look C"), (2, "Look B"), (2, "artist's cue")]  # the artist's marker stays
    plan = scene_state.read_show(scene)
    assert plan.fps == 10 and [look.label for look in plan.looks] == ["Look C", "Look B"]
    scene.render.fps = 20  # the scene's frame rate is the show's: the markers follow after the next update
    bpy.context.view_layer.update()
    assert marks() == [(1, "Look C"), (2, "artist's cue"), (3, "Look B")] and scene.frame_end == 4
    assert scene.lapig.show_looks[0].result_dir.startswith("//")  # relative to the .blend


def _render_here(scene, out_dir, frames=(1, 3)):
    paths = []
    for frame in frames:
        scene.frame_set(frame)
        scene.render.filepath = os.path.join(out_dir, f"frame_{frame}.png")
        bpy.ops.render.render(write_still=True)
        paths.append(scene.render.filepath)
    return paths


def _render_fresh(blend, out_dir):
    """Render frames 1 and 3 of `blend` in a new interpreter that imports bpy only."""
    os.makedirs(out_dir, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONSTARTUP")}
    done = subprocess.run([sys.executable, "-c", RENDER_SCRIPT, str(blend), str(out_dir)], cwd=str(out_dir),
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "ADDON-FREE True" in done.stdout, done.stdout[-2000:]
    return [os.path.join(out_dir, f"frame_{f}.png") for f in (1, 3)]


def _pixels(path):
    from lapig.lapig_core.common.imageio import read_image

    return read_image(path).astype(np.float64) * 255  # 8-bit levels


def test_the_baked_show_renders_without_the_addon_and_after_a_move(show_scene, tmp_path):
    from lapig.lapig_addon.blender import projector_nodes, scene_state, show_timeline
    from lapig.lapig_addon.services.show.show_jobs import BakeShowJob

    scene = show_scene
    source = show_timeline.show_source(scene, use_producer=False)  # the looks' stored images: plain numpy
    out = BakeShowJob(source, show_timeline.baked_folder()).run_to_completion()
    assert out["frames"] == 3
    show_timeline.baked(scene, out)
    projector = scene_state.rig_objects(scene)[0]
    image = projector_nodes.projected_image(projector.data)
    texture = projector.data.node_tree.nodes[projector_nodes.TEXTURE_NODE]
    assert image.source == "SEQUENCE" and image.filepath.startswith("//wall_lapig/shows/show/projector_1/")
    assert image.colorspace_settings.name == "Non-Color"
    user = texture.image_user
    assert (user.frame_duration, user.frame_start, user.frame_offset, user.use_auto_refresh) == (3, 1, 0, True)
    assert show_timeline.previz_status(scene) == ("Previz on the projector light: 3 frames at 10 fps", True)
    scene.frame_start = 2  # the show would start a frame later than its baked frames
    assert show_timeline.previz_status(scene)[1] is False
    scene.frame_start = 1
    # a projector setting rebuilds the light's nodes: the sequence and its conversion to light stay
    projector.lapig_projector.throw_ratio = projector.lapig_projector.throw_ratio
    assert projector.data.node_tree.nodes.get(projector_nodes.GAMMA_NODE) is not None
    scene.camera = scene_state.rig_objects(scene)[1]
    scene.render.engine = "CYCLES"
    scene.cycles.device, scene.cycles.samples = "CPU", 4
    scene.render.resolution_x, scene.render.resolution_y = RENDER
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    bpy.ops.wm.save_mainfile()
    blend = bpy.data.filepath
    here = [_pixels(p) for p in _render_here(scene, str(tmp_path / "with_addon"))]
    fresh = [_pixels(p) for p in _render_fresh(blend, tmp_path / "fresh")]
    means = [img.reshape(-1, 3).mean(0) for img in fresh]
    assert np.argmax(means[0]) == 0 and np.argmax(means[1]) == 2  # look A red, look C blue on the object
    assert np.abs(fresh[0] - fresh[1]).mean() > 20
    for a, b in zip(here, fresh):
        assert np.abs(a - b).mean() < 1.0  # the render the artist sees is the farm's
    # the .blend and its data folder moved together (a farm's shared storage): still the show
    moved = tmp_path / "farm" / "job"
    moved.mkdir(parents=True)
    bpy.ops.wm.read_homefile(use_empty=True)  # let go of the files before moving them
    shutil.move(blend, moved / "wall.blend")
    shutil.move(str(tmp_path / "wall_lapig"), moved / "wall_lapig")
    for texture in tmp_path.glob("surface_*.png"):  # the object's own texture, relative to the .blend too
        shutil.move(str(texture), moved / texture.name)
    after = [_pixels(p) for p in _render_fresh(moved / "wall.blend", tmp_path / "after_move")]
    for a, b in zip(fresh, after):
        assert np.abs(a - b).mean() < 1.0


def test_a_still_result_after_a_show_takes_the_light_back(show_scene):
    """Showing a result again (Generate, the export's bit depth) replaces the sequence and its conversion."""
    from lapig.lapig_addon.blender import projector_nodes, scene_state, show_timeline
    from lapig.lapig_addon.blender.result_sinks import ProjectorLightSink
    from lapig.lapig_addon.services.ports import ProjectorFrame
    from lapig.lapig_addon.services.show.show_jobs import BakeShowJob

    scene = show_scene
    out = BakeShowJob(show_timeline.show_source(scene, use_producer=False), show_timeline.baked_folder()).run_to_completion()
    show_timeline.baked(scene, out)
    projector = scene_state.rig_objects(scene)[0]
    texture = projector.data.node_tree.nodes[projector_nodes.TEXTURE_NODE]
    # a Capture or a Light Report borrows the light (its own sequence, its own frames) and gives the show back
    show_image = projector_nodes.projected_image(projector.data)
    borrowed = bpy.data.images.new("capture batch", 8, 8)
    projector_nodes.set_projected_image(projector.data, borrowed)
    texture.image_user.frame_duration, texture.image_user.frame_start = 5, 9
    assert projector.data.node_tree.nodes.get(projector_nodes.GAMMA_NODE) is None
    projector_nodes.set_projected_image(projector.data, show_image)
    assert (texture.image_user.frame_duration, texture.image_user.frame_start) == (3, 1)
    assert projector.data.node_tree.nodes[projector_nodes.GAMMA_NODE].inputs["Gamma"].default_value == \
        pytest.approx(projector.lapig_projector.gamma)
    assert show_timeline.previz_status(scene)[1] is True
    # the viewport's Projection preview (Material Preview, Solid) follows the scene's frame too
    from lapig.lapig_addon.blender import preview, result_preview

    assert result_preview.apply_mode(scene, "PROJECTION")
    target = scene_state.rig_objects(scene)[2]
    assert preview.current_preview(target)[0] == show_image
    tree = next(slot.material.node_tree for slot in target.material_slots if slot.material
                and slot.material.name.startswith(preview.PREVIEW_PREFIX))
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeTexImage" and n.image == show_image)
    assert (node.image_user.frame_duration, node.image_user.frame_start, node.image_user.use_auto_refresh) == \
        (3, 1, True)
    assert any(n.bl_idname == "ShaderNodeGamma" for n in tree.nodes)
    assert result_preview.apply_mode(scene, "ORIGINAL")
    ProjectorLightSink(scene).show(ProjectorFrame(np.full((48, 64, 3), 0.5, np.float32), 64, 48, 8))
    assert projector_nodes.projected_image(projector.data).source != "SEQUENCE"
    assert projector.data.node_tree.nodes.get(projector_nodes.GAMMA_NODE) is None
    text, ok = show_timeline.previz_status(scene)
    assert ok is False and "Bake Show again" in text


def test_show_export_refuses_in_one_line_and_writes_nothing(show_scene, tmp_path, capsys):
    """The command's bad input: a codec the installed FFmpeg lacks (before the .blend opens), no capture, a look
    older than the scene's capture, an empty show; each one line, status 1, no file."""
    from lapig.lapig_addon.blender import scene_state, storage
    from lapig.lapig_addon.cli.main import main

    scene = show_scene
    out = tmp_path / "export"

    def refused(*args):
        assert main(["show-export", "--out", str(out), *args]) == 1
        err = capsys.readouterr().err.strip()
        assert err.startswith("error: ") and "\n" not in err and "Traceback" not in err
        assert not out.exists()
        return err

    os.environ["LAPIG_FFMPEG"] = str(tmp_path / "no_ffmpeg")  # neither PyPI's PyAV nor this one has HAP
    try:
        assert "hap" in refused("--blend", str(tmp_path / "nowhere.blend"), "--codec", "hap").lower()
    finally:
        del os.environ["LAPIG_FFMPEG"]
    assert refused("--codec", "mpeg2").startswith("error: unknown codec 'mpeg2'")
    bpy.ops.wm.save_mainfile()
    blend = bpy.data.filepath
    assert refused("--blend", blend, "--codec", "png") == \
        "error: The show's looks need the scene's capture: capture the surface first"
    scene = bpy.context.scene
    capture = os.path.join(storage.data_root()[0], "panel", "setups", "panel")
    os.makedirs(capture)
    with open(os.path.join(capture, "setup.json"), "w") as f:
        f.write("{}")
    scene_state.record_capture(scene, capture, scene_state.read_rig(scene).fingerprint)
    bpy.ops.wm.save_mainfile()
    assert refused("--blend", blend, "--codec", "png") == \
        "error: Look 1 'Look A' is older than the scene's capture (captured again since): generate it again"
    scene = bpy.context.scene
    while scene.lapig.show_looks:
        scene_state.remove_show_look(scene, 0)
    assert not [m for m in scene.timeline_markers if m.name.startswith("Look")]
    bpy.ops.wm.save_mainfile()
    assert refused("--blend", blend, "--codec", "png") == "error: The show has no looks: add a result to it (Add Look)"


@pytest.mark.torch
def test_a_show_of_generated_looks_is_baked_and_exported_through_the_producer(captured, tmp_path, capsys,
                                                                              monkeypatch):
    """Capture, two looks generated (the first look's classical model), a morph between them: Bake Show, Export
    Show (operator and command), Play Show and show --timeline make their frames through lapig_core/show's
    producer."""
    import json

    from lapig.lapig_addon.blender import projector_nodes, scene_state, show_timeline
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.cli.main import main
    from lapig.lapig_addon.services.show import show_source
    from lapig.lapig_addon.services.generate.generate_job import GenerateJob

    scene = captured
    for prompt in ("stained glass", "ink wash"):
        request = scene_state.generate_request(scene, prompt=prompt)
        folder = GenerateJob(scene_seams(scene), request).run_to_completion()["folder"]
        assert bpy.ops.lapig.show_add_look(directory=folder) == {"FINISHED"}
    scene.render.fps = 10
    scene_state.set_show_look(scene, 0, hold_s=0.2, transition="morph", transition_s=0.3)
    scene_state.set_show_look(scene, 1, hold_s=0.2, motion="pulse", motion_period_s=1.0)
    assert [m.name for m in sorted(scene.timeline_markers, key=lambda m: m.frame)] == [
        "stained glass", "morph 0.3s to ink wash", "ink wash"]
    assert show_timeline.blocker(scene) == "" and show_source.uses_producer(show_timeline.show_source(scene))
    assert bpy.ops.lapig.bake_show() == {"FINISHED"}
    assert show_timeline.previz_status(scene) == ("Previz on the projector light: 7 frames at 10 fps", True)
    folder, _ = scene_state.show_baked(scene)
    assert json.load(open(os.path.join(folder, "show.json")))["producer"] == "lapig_core.show"
    projector = scene_state.rig_objects(scene)[0]
    assert projector_nodes.projected_image(projector.data).source == "SEQUENCE"
    size = tuple(scene_state.projector_size(projector))  # read now: the commands open the .blend again
    scene.lapig.show_codec, scene.lapig.show_export_dir = "png", str(tmp_path / "by_operator")
    assert bpy.ops.lapig.export_show() == {"FINISHED"}
    frames = sorted(os.listdir(tmp_path / "by_operator" / "show"))
    assert frames[:2] == ["frame_000001.png", "frame_000002.png"] and "frame_000007.png" in frames
    bpy.ops.wm.save_mainfile()
    capsys.readouterr()
    assert main(["show-export", "--blend", bpy.data.filepath, "--out", str(tmp_path / "by_command"),
                 "--codec", "png", "--bit-depth", "16"]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["frames"] == 7 and printed["fps"] == 10.0 and printed["codec"] == "png"
    sidecar = json.load(open(tmp_path / "by_command" / "show.json"))
    assert sidecar["bit_depth"] == 16 and sidecar["show"]["looks"][1]["motion"]["kind"] == "pulse"
    if not show_source.codec_problem("h264"):  # PyAV here: the video a media server plays
        assert main(["show-export", "--blend", bpy.data.filepath, "--out", str(tmp_path / "video"),
                     "--codec", "h264"]) == 0
        printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert printed["outputs"][0]["path"].endswith("show.mp4") and printed["frames"] == 7
        assert json.load(open(tmp_path / "video" / "show.json"))["show"]["fps"] == 10.0
    # Play Show (the panel) and show --timeline (the command) on a stand-in projector window
    from lapig.lapig_addon.rigs import live_output
    from lapig.lapig_core.rig import projector_window

    class Window:
        def __init__(self, display, **kw):
            self.size, self.is_open, self.shown = size, True, []

        def show(self, pixels):
            import time

            self.shown.append(pixels)
            return time.perf_counter()

        def describe(self):
            return {"display": {"index": 1, "name": "stand-in"}}

        def close(self):
            self.is_open = False

    window = Window(1)
    live_output.open_live("1", window_factory=lambda display: window)
    try:
        assert bpy.ops.lapig.play_show() == {"FINISHED"}
    finally:
        live_output.close_live()
    assert len(window.shown) == 7 and window.shown[0].dtype == np.uint8
    monkeypatch.setattr(projector_window, "ProjectorWindow", Window)
    capsys.readouterr()
    assert main(["show", "--timeline", "--blend", bpy.data.filepath, "--display", "1"]) == 0
    played = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["show"]
    assert played["frames"] == 7 and {"late_frames", "late_frame_pct"} <= set(played)


def test_the_show_panel_draws_the_list_the_blocker_and_the_buttons(show_scene):
    from test_panels import RecordingLayout, sentences

    from lapig.panels.show_panel import LAPIG_PT_show

    class Layout(RecordingLayout):
        def _child(self, *args, **kwargs):
            return Layout(self.log)

        row = column = box = split = _child

        def template_list(self, *args, **kwargs):
            self.log.append(("list", args[3]))

    def draw():
        log = []
        LAPIG_PT_show.draw(type("P", (), {"layout": Layout(log)})(), bpy.context)
        return log

    log = draw()
    texts = sentences(log)
    assert ("list", "show_looks") in log and ("prop", "hold_s") in log and ("prop", "motion") in log
    assert "3 frames, 0.3 s at 10 fps (the scene's frame rate)" in texts
    assert "The show's looks need the scene's capture: capture the surface first" in texts
    assert "No previz baked yet: Bake Show puts the show on the timeline" in texts
    ops = [entry[1] for entry in log if entry[0] == "operator"]
    for op in ("lapig.show_add_look", "lapig.show_remove_look", "lapig.show_move_look", "lapig.bake_show",
               "lapig.export_show", "lapig.play_show"):
        assert op in ops
    scene = bpy.context.scene
    while scene.lapig.show_looks:
        assert bpy.ops.lapig.show_remove_look() == {"FINISHED"}
    texts = sentences(draw())
    assert "The show has no looks: add a result to it (Add Look)" in texts  # a scene without a show reads so
    assert bpy.ops.lapig.show_remove_look() == {"CANCELLED"}


def test_the_scenes_sound_strips_in_the_shows_range_are_mixed_down_for_the_export(show_scene, tmp_path):
    """Export Show's sound (issue 52): the sound strips that play in the scene's range, mixed down by Blender to
    48 kHz stereo over that range; a muted strip or none: no sound."""
    import wave

    from lapig.lapig_addon.blender import show_timeline

    scene = show_scene
    assert show_timeline.show_sound(scene) is None  # no sound strips
    tone = tmp_path / "tone.wav"
    with wave.open(str(tone), "wb") as w:
        w.setnchannels(1), w.setsampwidth(2), w.setframerate(44100)
        t = np.arange(44100) / 44100
        w.writeframes((8000 * np.sin(2 * np.pi * 440 * t)).astype("<i2").tobytes())
    if scene.sequence_editor is None:
        scene.sequence_editor_create()
    strip = scene.sequence_editor.strips.new_sound("tone", str(tone), 1, scene.frame_start + 2)
    try:
        path = show_timeline.show_sound(scene)
        fps = scene.render.fps / scene.render.fps_base
        frames = scene.frame_end - scene.frame_start + 1  # the show's range (the show sets the scene's)
        with wave.open(path, "rb") as w:
            assert (w.getframerate(), w.getnchannels()) == (48000, 2)
            assert w.getnframes() == pytest.approx(48000 * frames / fps, abs=48000 / fps)
            samples = np.frombuffer(w.readframes(w.getnframes()), "<i2").reshape(-1, 2)
        onset = np.argmax(np.abs(samples[:, 0]) > 1000) / 48000  # the strip starts 2 frames in
        assert onset == pytest.approx(2 / fps, abs=1 / fps)
        shutil.rmtree(os.path.dirname(path))
        strip.mute = True
        assert show_timeline.show_sound(scene) is None
    finally:
        scene.sequence_editor.strips.remove(strip)
