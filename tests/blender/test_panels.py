import importlib.util

import bpy
import pytest


class RecordingLayout:
    """Stands in for UILayout: records what a panel draws and checks every property exists."""

    def __init__(self, log):
        self.log = log
        self.enabled = True

    def _child(self, *args, **kwargs):
        return RecordingLayout(self.log)

    row = column = box = split = _child

    def prop(self, data, name, **kwargs):
        assert hasattr(data, name) or name in data.bl_rna.properties, f"no property {name} on {data}"
        self.log.append(("prop", name))

    def operator(self, idname, **kwargs):
        module, _, op = idname.partition(".")
        assert hasattr(getattr(bpy.ops, module), op), f"no operator {idname}"
        self.log.append(("operator", idname))
        return type("Props", (), {})()

    def operator_menu_enum(self, idname, prop, **kwargs):
        module, _, op = idname.partition(".")
        rna = getattr(getattr(bpy.ops, module), op).get_rna_type()
        assert prop in rna.properties, f"no property {prop} on operator {idname}"
        self.log.append(("operator", idname))

    def label(self, text="", icon="NONE", **kwargs):
        self.log.append(("label", text, icon))

    def progress(self, **kwargs):
        self.log.append(("progress", kwargs.get("text")))

    def separator(self, **kwargs):
        self.log.append(("separator", None))


def sentences(log):
    """The labels' texts, a wrapped sentence whole again (the panels draw its next lines with the BLANK1 icon)."""
    texts = []
    for entry in log:
        if entry[0] == "label":
            if entry[2] == "BLANK1" and texts:
                texts[-1] += " " + entry[1]
            else:
                texts.append(entry[1])
    return texts


def draw_panels(context, log):
    """Every panel as Blender draws it: those whose poll() says no are left out."""
    from lapig.panels.main_panel import CLASSES

    for cls in CLASSES:
        if not hasattr(cls, "poll") or cls.poll(context):
            cls.draw(type("P", (), {"layout": RecordingLayout(log)})(), context)
    return log


@pytest.mark.blender
@pytest.mark.parametrize("with_rig", [False, True])
def test_panels_draw_with_and_without_a_rig(lapig_registered, small_setup, with_rig):
    if not with_rig:
        s = bpy.context.scene.lapig
        s.projector = s.camera = s.target = None
    log = draw_panels(bpy.context, [])
    texts = [entry[1] for entry in log if entry[0] == "label"]
    said = " ".join(texts)  # the sentences, wrapped at the sidebar's width
    assert "temporary folder" in said  # unsaved file: the UI says so
    # every step of the artist's path is there, in order
    ops = [entry[1] for entry in log if entry[0] == "operator"]
    for op in ("lapig.add_rig", "lapig.capture", "lapig.train_models", "lapig.generate", "lapig.render_result",
               "lapig.export_image", "lapig.export_crossfade"):
        assert op in ops
    assert ops.index("lapig.capture") < ops.index("lapig.train_models") < ops.index("lapig.generate")
    assert ("prop", "prompt") in log and ("prop", "use_psa") in log and ("prop", "preview_mode") in log
    if with_rig and importlib.util.find_spec("torch") is None:  # the version matrix's torch-free venvs
        assert "Missing: torch" in texts and "Install torch (see the add-on preferences)" in said
        assert ("prop", "throw_ratio") in log and ("operator", "lapig.capture") in log
    elif with_rig:
        assert "Capture the surface first" in said  # what blocks the next step is shown
        assert ("prop", "throw_ratio") in log and ("operator", "lapig.capture") in log
    else:
        assert "Add the projector and camera first" in said


@pytest.mark.blender
def test_the_style_image_property_reaches_the_generate_request(lapig_registered, small_setup, tmp_path):
    from lapig.lapig_addon.blender import scene_state

    scene = bpy.context.scene
    s = scene.lapig
    assert scene_state.generate_request(scene).style_images == ()  # none chosen: the prompt's look
    s.style_image, s.style_prompt_weight = str(tmp_path / "missing painting.png"), 0.3
    request = scene_state.generate_request(scene)
    assert request.style_images == (str(tmp_path / "missing painting.png"),)
    assert request.lgst_backend() == "arbitrary" and request.style_prompt_weight == pytest.approx(0.3)
    assert request.problem().startswith("style image not found")  # the panel shows why Generate waits
    log = draw_panels(bpy.context, [])
    assert ("prop", "style_image") in log and ("prop", "style_prompt_weight") in log
    scene_state.write_stylize_settings(scene, scene_state.generate_request(scene, style_images=()))
    assert s.style_image == ""


@pytest.mark.blender
def test_no_line_of_any_panel_is_cut_at_250_350_and_500_px(lapig_registered, tmp_path):
    """bench ui's cut_lines: every LAPIG panel in each scene state (fresh, rigged, captured, unsaved, with a result,
    without torch, a real rig), measured with Blender's font at UI scale 1."""
    from lapig.tools.bench.panel_cuts import cut_lines

    figures = cut_lines(str(tmp_path), pictures=False)
    assert figures["cut_lines"] == 0, figures["cut_lines_listed"]
    assert figures["panel_lines_measured"] > 1000
    assert not bpy.data.filepath  # the states' saved file is closed again


@pytest.mark.blender
def test_without_torch_capture_is_on_and_what_waits_for_torch_says_so(lapig_registered, tmp_path):
    from lapig.tools.bench import panel_cuts

    scene = dict((name, make) for name, make, _ in panel_cuts.states(str(tmp_path)))["captured"]()
    with panel_cuts._without_torch():
        lines = [entry["line"] for entry in panel_cuts.draw(scene, 250, 1.0, panel_cuts.measure_for(1.0))]
    buttons = {line.text: line.enabled for line in lines if line.kind == "operator"}
    assert buttons["Capture"] and buttons["Import Capture Folder"] and buttons["Preview Projection"]
    assert not buttons["Train Models"] and not buttons["Generate"]
    said = " ".join(line.text for line in lines if line.kind == "label")
    assert said.count("Install torch (see the add-on preferences)") >= 2  # above Train and above Generate
    bpy.ops.wm.read_factory_settings(use_empty=True)


@pytest.mark.blender
def test_a_play_button_off_until_the_projector_window_opens_says_so_in_its_tooltip(lapig_registered, small_setup):
    from lapig.lapig_addon.rigs import live_output
    from lapig.operators.real_rig_ops import LAPIG_OT_play_crossfade
    from lapig.operators.show_ops import LAPIG_OT_play_show

    assert not live_output.open_sinks()
    assert LAPIG_OT_play_show.description(bpy.context, None).endswith(
        ".\nShow on Projector first: the show plays in the projector window")
    assert LAPIG_OT_play_crossfade.description(bpy.context, None).endswith(
        ".\nShow on Projector first: the crossfade plays in the projector window")
