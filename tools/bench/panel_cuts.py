"""`bench ui --parts panel`: the LAPIG panels drawn in 10 scene states (fresh, rigged, captured in a saved file or
unsaved, with a result, without torch, a real rig, two projectors) at sidebar widths of 250, 350 and
500 px (UI scale 1, and 1.25 apart; Blender's 220 px first width apart too) through panel_layout's measuring
layout; `cut_lines` counts the lines Blender would clip (an object's name in its field, the artist's to choose, is
counted apart: `cut_names_by_width`; the lines the panel shortened itself, a path to its tail or a name to its
start with an ellipsis: `shortened_lines_by_width`). With `--out`, pictures of a few states
(panel_<state>_<width>.png: each button's box at its width, its text, cut ones in red).
"""
from __future__ import annotations

import contextlib
import os
from types import SimpleNamespace

from ...lapig_addon.services.panel import text_fit
from .panel_layout import MeasuringLayout, RNAChecks

WIDTHS = (250, 350, 500)
SCALES = (1.0, 1.25)
FIRST_WIDTH = int(text_fit.SIDEBAR_WIDTH)  # the sidebar as Blender first opens it, at scale 1
PICTURES = (("rig", 250), ("captured", 250), ("no_torch", 250), ("result", 350), ("real_rig", 250),
            ("two_projectors", 250))
FIRST_LOOK = "First look: classical model (fitted in 0.1 s); Train for the networks"


def _preferences(scale: float):
    view = SimpleNamespace(ui_scale=scale)
    system = SimpleNamespace(ui_scale=scale)
    style = SimpleNamespace(widget=SimpleNamespace(points=text_fit.UI_POINTS))
    return SimpleNamespace(view=view, system=system, ui_styles=[style])


def panel_classes():
    """Every LAPIG panel, in the sidebar's order."""
    from ...panels import light_panel, main_panel, show_panel

    import bpy

    return [c for c in (*main_panel.CLASSES, *light_panel.CLASSES, *show_panel.CLASSES)
            if issubclass(c, bpy.types.Panel)]


def draw(scene, width: int, scale: float, measure) -> list[dict]:
    """Every line the panels draw for `scene` in a sidebar `width` px wide, measured: dicts of the panel, the
    text, its width and its room."""
    import bpy

    context = SimpleNamespace(scene=scene, region=SimpleNamespace(width=width), preferences=_preferences(scale),
                              space_data=None, active_object=None)
    inner = text_fit.content_width(width, scale)
    checks = RNAChecks(bpy.ops)
    out = []
    for cls in panel_classes():
        if hasattr(cls, "poll") and not cls.poll(context):
            continue
        header = SimpleNamespace(kind="header", text=cls.bl_label, text_px=measure(cls.bl_label),
                                 room_px=text_fit.label_room(inner, scale, icon=True), width_px=inner, x=0, row=-1,
                                 icon=True, enabled=True)
        header.cut = header.text_px > header.room_px + 0.5
        layout = MeasuringLayout(checks=checks)
        cls.draw(SimpleNamespace(layout=layout), context)
        for line in [header] + layout.resolve(inner, scale, measure):
            out.append({"panel": cls.bl_idname, "line": line})
    return out


# ------------------------------------------------------------------------------------------ the scene states

def _rigged(folder):
    import bpy

    from ...lapig_addon.blender import rig
    from ...lapig_addon.cli import headless

    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=folder,
                                                                 camera_resolution=(160, 120))
    rig.add_rig(bpy.context, target, projector, camera)
    return scene


def _saved(scene, folder):
    import bpy

    os.makedirs(folder, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "wall.blend"))
    return bpy.context.scene


def _captured(scene):
    from ...lapig_addon.blender import scene_state, storage

    rig = scene_state.read_rig(scene)
    folder = os.path.join(storage.capture_root("Wall"), "capture_0001")
    os.makedirs(folder, exist_ok=True)
    scene_state.record_capture(scene, folder, rig.fingerprint, rig.transport)
    scene_state.record_models(scene, "", FIRST_LOOK)
    return scene


def _with_result(scene):
    import numpy as np

    from ...lapig_addon.blender import scene_state, storage
    from ...lapig_core.export.result_files import write_result

    w, h = scene_state.read_rig(scene).projector_size
    ramp = np.broadcast_to(np.linspace(0, 1, w, dtype=np.float32)[None, :, None], (h, w, 3)).copy()
    folder = write_result(os.path.join(storage.data_root()[0], "result_stained_glass"),
                          {"projector": ramp, "target": ramp}, {"prompt": "bench"})
    scene_state.record_models(scene, scene_state.read(scene).capture_fingerprint,
                              "Fine-tuned for this capture: CompenNeSt chosen on the rendered test images")
    scene_state.record_result(
        scene, str(folder), "Read as: stained glass 70%, mosaic 30% | 'shimmering' matched no style word",
        reach_message="Most of this look is out of the surface's reach: its dark red parts cannot show the "
                      "bright greens of the look; try a lighter style or a lower adaptation")
    return scene


def _two_projectors(scene):
    """A second projector, captured with the first: the Projectors box with each one's share of the object."""
    import bpy

    from ...lapig_addon.blender import multi_rig, scene_state

    multi_rig.add_projector(bpy.context)
    _captured(scene)
    names = scene_state.read_rig(scene).projectors
    scene_state.record_coverage(scene, names, [0.62, 0.55][:len(names)], 0.91)
    return scene


def _real(scene):
    s = scene.lapig
    s.rig_kind, s.real.display, s.real.camera, s.real.camera_source = "REAL", "1", "0", "DEVICE"
    return scene


@contextlib.contextmanager
def _without_torch():
    """torch as missing as in a Blender without it: the dependency check and the style backend's check."""
    from ...lapig_addon.services.panel import panel_state
    from ...lapig_core.common import deps

    real = deps.check_dependencies
    cache = dict(panel_state._AVAILABILITY)

    def check():
        return [deps.Dependency(d.module, d.package, d.hint, d.present and d.module != "torch", d.required)
                for d in real()]

    deps.check_dependencies = check
    panel_state._AVAILABILITY.clear()
    original = panel_state.backend_warning

    def warning(request):  # what backend_class's import gives without torch
        return "No module named 'torch'"

    panel_state.backend_warning = warning
    try:
        yield
    finally:
        deps.check_dependencies = real
        panel_state.backend_warning = original
        panel_state._AVAILABILITY.clear()
        panel_state._AVAILABILITY.update(cache)


def states(folder):
    """(name, make the scene, context manager) for each state the panels are drawn in."""
    from ...lapig_addon.blender import demo_scene

    def fresh():
        return demo_scene.new_empty_scene()

    def rigged():
        fresh()
        return _rigged(os.path.join(folder, "demo"))

    def captured():
        return _captured(_saved(rigged(), folder))

    def result():
        return _with_result(captured())

    def unsaved_captured():
        return _captured(rigged())

    return [("fresh", fresh, contextlib.nullcontext), ("rig", rigged, contextlib.nullcontext),
            ("captured", captured, contextlib.nullcontext), ("unsaved_captured", unsaved_captured,
                                                               contextlib.nullcontext),
            ("result", result, contextlib.nullcontext), ("no_torch", captured, _without_torch),
            ("no_torch_result", result, _without_torch), ("real_rig", lambda: _real(captured()),
                                                          contextlib.nullcontext),
            ("two_projectors", lambda: _two_projectors(captured()), contextlib.nullcontext),
            ("real_two_projectors", lambda: _real(_two_projectors(captured())), contextlib.nullcontext)]


def measure_for(scale):
    from ...lapig_addon.blender import ui_text

    return ui_text.blf_measure(text_fit.UI_POINTS * scale)


def cut_lines(out: str | None = None, pictures: bool = True) -> dict:
    """The panels in every state at every width: the cut lines counted and listed."""
    folder = os.path.abspath(os.path.join(out or "out/bench_ui", "panel"))
    os.makedirs(folder, exist_ok=True)
    counts = {}  # (scale, width) -> cut lines
    name_counts = {}  # (scale, width) -> objects' names cut in their fields
    shortened = {}  # (scale, width) -> lines the panel itself shortened to fit (a path's tail, a name's start)
    listed = []
    drawn = 0
    written = []
    for name, make, condition in states(folder):
        scene = make()
        with condition():
            for scale in SCALES:
                for width in (FIRST_WIDTH, *WIDTHS):
                    if scale != 1.0 and width == FIRST_WIDTH:
                        continue
                    lines = draw(scene, width, scale, measure_for(scale))
                    drawn += len(lines)
                    shortened[(scale, width)] = shortened.get((scale, width), 0) + sum(
                        text_fit.ELLIPSIS in entry["line"].text for entry in lines)
                    cut = [entry for entry in lines if entry["line"].cut]
                    names = [entry for entry in cut if getattr(entry["line"], "user_name", False)]
                    counts[(scale, width)] = counts.get((scale, width), 0) + len(cut) - len(names)
                    name_counts[(scale, width)] = name_counts.get((scale, width), 0) + len(names)
                    for entry in cut:
                        line = entry["line"]
                        listed.append({"name": getattr(line, "user_name", False), "state": name, "width": width, "scale": scale, "panel": entry["panel"],
                                       "kind": line.kind, "text": line.text, "text_px": round(line.text_px),
                                       "room_px": round(line.room_px)})
                    if pictures and scale == 1.0 and (name, width) in PICTURES:
                        path = picture(lines, width, scale, os.path.join(folder, f"panel_{name}_{width}.png"))
                        if path:
                            written.append(path)
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)  # the states' saved file closed: a fresh one, as before
    main = {w: counts[(1.0, w)] for w in WIDTHS}
    return {"cut_lines": sum(main.values()),
            "cut_lines_by_width": main,
            "cut_lines_ui_scale_1_25": {w: counts[(1.25, w)] for w in WIDTHS},
            "cut_lines_first_width_220": counts[(1.0, FIRST_WIDTH)],
            "cut_names_by_width": {w: name_counts[(1.0, w)] for w in WIDTHS},
            "shortened_lines_by_width": {w: shortened[(1.0, w)] for w in WIDTHS},
            "cut_lines_listed": [e for e in listed if not e["name"] and e["scale"] == 1.0 and e["width"] in WIDTHS],
            "cut_lines_listed_other": [e for e in listed if e["name"] or not (e["scale"] == 1.0
                                                                              and e["width"] in WIDTHS)],
            "panel_lines_measured": drawn, "panel_states": [n for n, _, _ in states(folder)],
            "panel_pictures": written}


def picture(lines, width, scale, path):
    """The measured layout as a picture: each button's box at its width with its text, cut ones red."""
    try:
        from PIL import Image, ImageDraw, ImageFont
    except ImportError:
        return None
    row_h = int(text_fit.UNIT * scale * 1.1)
    rows = {}
    panel_rows = []  # each panel's lines on rows of their own, the panels one after the other
    offset = 0
    for entry in lines:
        line = entry["line"]
        if line.kind == "header":
            offset = (max(rows.values()) + 2) if rows else 0
            rows[entry["panel"]] = offset
        r = offset + line.row + 1
        rows[entry["panel"]] = max(rows[entry["panel"]], r)
        panel_rows.append((r, line))
    height = (max(r for r, _ in panel_rows) + 2) * row_h if panel_rows else row_h
    image = Image.new("RGB", (width, height), (48, 48, 48))
    pen = ImageDraw.Draw(image)
    try:
        font = ImageFont.truetype("DejaVuSans.ttf", int(round(text_fit.UI_POINTS * scale)))
    except OSError:
        font = ImageFont.load_default()
    left = scale * (text_fit.TABS + text_fit.PANEL_MARGIN + text_fit.PANEL_SPACE)
    pen.rectangle([0, 0, scale * text_fit.TABS, height], fill=(35, 35, 35))
    for r, line in panel_rows:
        x0, y0 = left + line.x, r * row_h
        x1 = x0 + max(2.0, line.width_px) - 2
        colour = (200, 60, 60) if line.cut else ((90, 90, 90) if line.kind != "header" else (70, 70, 110))
        pen.rectangle([x0, y0 + 1, x1, y0 + row_h - 2], outline=colour, fill=(60, 60, 60) if line.enabled
                      else (52, 52, 52))
        if line.text:  # drawn in another font, squeezed or stretched to the width blf measured
            tx = x0 + scale * ((text_fit.ICON if line.icon else 0) + text_fit.TEXT_PADDING)
            colour = (255, 120, 120) if line.cut else ((220, 220, 220) if line.enabled else (140, 140, 140))
            box = pen.textbbox((0, 0), line.text, font=font)
            word = Image.new("RGB", (max(1, box[2]), row_h), (60, 60, 60) if line.enabled else (52, 52, 52))
            ImageDraw.Draw(word).text((0, 3), line.text, fill=colour, font=font)
            word = word.resize((max(1, int(round(line.text_px))), row_h))
            image.paste(word, (int(tx), int(y0)))
    image.save(path)
    return path
