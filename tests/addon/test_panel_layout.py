"""bench ui's measuring layout (tools/bench/panel_layout): the widths it gives each line and what it calls cut,
with fake RNA data (a fixed width per character)."""
import importlib
from types import SimpleNamespace

import pytest

CHAR = 6.0


@pytest.fixture
def layout_module():
    return importlib.import_module("lapig.tools.bench.panel_layout")


def measure(text):
    return len(text) * CHAR


def rna(**props):
    """Fake data whose bl_rna.properties are `props` (name -> SimpleNamespace(type, name, ...))."""
    values = {key: prop.value for key, prop in props.items()}
    data = SimpleNamespace(**values)
    data.bl_rna = SimpleNamespace(properties=props)
    return data


def enum(name, value, *items):
    return SimpleNamespace(type="ENUM", name=name, value=value,
                           enum_items=[SimpleNamespace(identifier=i, name=n) for i, n in items])


def number(name, value, kind="INT"):
    return SimpleNamespace(type=kind, name=name, value=value, is_array=False, precision=2, unit="NONE")


def lines_of(layout_module, draw, width=198.0):
    layout = layout_module.MeasuringLayout()
    draw(layout)
    return layout.resolve(width, 1.0, measure)


def test_a_label_gets_the_width_less_its_padding_and_icon(layout_module):
    lines = lines_of(layout_module, lambda l: (l.label(text="x" * 20, icon="INFO"), l.label(text="x" * 20)))
    assert lines[0].room_px == 198 - 8 - 5 - 20 and not lines[0].cut
    assert lines[1].room_px == 198 - 8 - 5
    long = lines_of(layout_module, lambda l: l.label(text="x" * 40, icon="ERROR"))[0]
    assert long.cut and long.text_px == 240


def test_a_row_shares_its_width_and_an_icon_button_takes_a_unit(layout_module):
    data = rna(width=number("Width", 800), height=number("Height", 600))

    def draw(layout):
        row = layout.row(align=True)
        row.prop(data, "width")
        row.prop(data, "height")
        row = layout.row(align=True)
        row.label(text="Projector 2")
        row.operator("lapig.remove_projector", text="", icon="X")

    w, h, label, button = lines_of(layout_module, draw)
    assert w.width_px == h.width_px == 99 and h.x == 99 and w.row == h.row
    assert w.text == "Width: 800" and w.room_px == 99 - 16 - 5
    assert label.width_px == 198 - 20 and button.width_px == 20 and not button.cut
    assert label.row == w.row + 1


def test_a_menu_with_a_name_gives_its_label_a_third(layout_module):
    data = rna(transport=enum("Light transport", "REALISTIC", ("REALISTIC", "Realistic"), ("FAST", "Fast")))
    label, value = lines_of(layout_module, lambda l: l.prop(data, "transport"))
    assert label.width_px == pytest.approx(66) and label.cut  # "Light tr..." in Blender
    assert value.text == "Realistic" and value.width_px == pytest.approx(132) and not value.cut
    short = lines_of(layout_module, lambda l: l.prop(data, "transport", text="Light"))[0]
    assert not short.cut


def test_an_expanded_menu_goes_across_the_panel_and_down_a_column(layout_module):
    data = rna(mode=enum("Show", "A", ("A", "Original"), ("B", "Projection"), ("C", "Target")))
    across = lines_of(layout_module, lambda l: l.prop(data, "mode", expand=True))
    assert [line.width_px for line in across] == [66, 66, 66] and len({line.row for line in across}) == 1
    down = lines_of(layout_module, lambda l: l.column().prop(data, "mode", expand=True))
    assert [line.width_px for line in down] == [198, 198, 198] and len({line.row for line in down}) == 3


def test_a_box_and_a_split_narrow_their_lines(layout_module):
    data = rna(use_psa=SimpleNamespace(type="BOOLEAN", name="Surface adaptation (PSA)", value=True),
               amount=number("Adaptation", 0.5, "FLOAT"))

    def draw(layout):
        layout.box().label(text="in a box")
        split = layout.split(factor=0.35)
        split.prop(data, "use_psa")
        split.prop(data, "amount")

    boxed, check, amount = lines_of(layout_module, draw)
    assert boxed.width_px == 198 - 10
    assert check.width_px == pytest.approx(0.35 * 198) and check.cut  # the long name: "Surface adapta..."
    assert amount.text == "Adaptation: 0.50" and amount.width_px == pytest.approx(0.65 * 198)
