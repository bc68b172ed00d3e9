"""A recording stand-in for Blender's UILayout that measures each line a panel draws against the width the
layout gives it (bench ui's `cut_lines`).

A panel draws into `MeasuringLayout` as into Blender's; `resolve(width)` then hands out the widths as Blender's
layout does in a sidebar panel without property split (source/blender/editors/interface/interface_layout.cc):
- a column and a box give each item their width (a box less its space each side); a row shares its width
  equally among its items, but for icon-only buttons (one unit each); a split gives its first column
  `factor` of it and shares the rest;
- a label draws its text after the text padding (and its icon); an operator centres its text (and icon);
- a property with a name as a menu (enum), an object field or a text field: a label of a third of the width
  and the field in the rest (`ui_item_with_label`: `w_hint / 3`); a number: "Name: value" inside the field; a
  check box: its name after the box; an expanded enum: one button per item (across a row, down a column);
- text is measured with `measure` (Blender's font, through blf, where the bench runs in Blender).
A line is cut when its text is wider than what its width leaves it: Blender would clip it ("Surface ...").
Text fields' values (a prompt, a path being edited) scroll in Blender and are not counted.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

from ...lapig_addon.services.panel import text_fit

U = text_fit.UNIT


@dataclass
class Line:
    """One measured piece of text: what it says, how wide it is and how wide its place is (pixels)."""
    kind: str  # 'label', 'operator', 'prop label', 'prop value', 'number', 'check box', 'enum item', ...
    text: str
    text_px: float = 0.0
    room_px: float = 0.0
    width_px: float = 0.0  # the whole button's width (its box in the picture)
    icon: bool = False
    enabled: bool = True
    x: float = 0.0  # the button's left edge in the panel (for the picture)
    row: int = 0  # the button's row in the panel (for the picture)

    @property
    def cut(self) -> bool:
        return bool(self.text) and self.text_px > self.room_px + 0.5  # half a pixel: Blender's own rounding

    @property
    def user_name(self) -> bool:
        """An object's name in its field: the artist's to choose, counted apart (Blender clips it in the middle)."""
        return self.kind == "pointer value"


@dataclass
class Node:
    kind: str  # 'column', 'row', 'box', 'split'
    factor: float = 0.0
    children: list = field(default_factory=list)
    enabled: bool = True


@dataclass
class Item:
    kind: str  # 'label', 'operator', 'prop', 'progress', 'separator', 'opaque'
    text: str = ""
    icon: bool = False
    fixed: bool = False  # icon only: one unit wide in a row
    parts: tuple = ()  # (kind, text, icon) of a prop's pieces, laid out by resolve
    count: int = 1  # an expanded enum: its items
    enabled: bool = True


def _icon(icon) -> bool:
    return bool(icon) and icon != "NONE"


def _value_text(data, name, prop) -> str:
    """What a number field shows after its name: the value as Blender prints it (close enough to measure)."""
    value = getattr(data, name)
    if prop.type == "INT":
        return str(value)
    unit = {"LENGTH": " m", "POWER": " W", "TIME_ABSOLUTE": " s"}.get(getattr(prop, "unit", "NONE"), "")
    return f"{value:.{max(0, min(getattr(prop, 'precision', 3), 6))}f}{unit}"


def prop_parts(data, name, text=None, icon="NONE", expand=False, toggle=False, in_row=False):
    """What a property button draws, as (kind, text, icon) pieces and whether it is icon-only: from its RNA."""
    prop = data.bl_rna.properties[name]
    label = prop.name if text is None else text
    has_icon = _icon(icon)
    if prop.type == "BOOLEAN":
        if not label:
            return [("check box", "", True)], True
        return [("toggle" if toggle else "check box", label, True)], False
    if prop.type == "ENUM":
        items = [item.name for item in prop.enum_items] if not callable(getattr(prop, "enum_items", None)) else []
        if expand:
            return [("enum item", item, False) for item in items], False
        value = getattr(data, name)
        shown = next((item.name for item in prop.enum_items if item.identifier == value), str(value))
        parts = [("prop label", label, False)] if label else []
        return parts + [("enum value", shown, has_icon)], False
    if prop.type in ("INT", "FLOAT"):
        if getattr(prop, "is_array", False) and getattr(prop, "array_length", 0) > 1:
            return [("opaque", label, False)], False
        return [("number", f"{label}: {_value_text(data, name, prop)}" if label else _value_text(data, name, prop),
                 has_icon)], False
    if prop.type == "POINTER":
        value = getattr(data, name)
        parts = [("prop label", label, False)] if label else []
        return parts + [("pointer value", getattr(value, "name", "") if value is not None else "", True)], False
    # strings: the label; the value is an edit field that scrolls
    parts = [("prop label", label, False)] if label else []
    return parts + [("text field", "", False)], False


class MeasuringLayout:
    """Stands in for bpy.types.UILayout: builds the tree of what a panel draws (see the module's text)."""

    def __init__(self, node: Node | None = None, checks=None):
        self._node = node or Node("root")
        self._checks = checks  # (data, name) -> None: raises where a property or an operator is missing
        self.use_property_split = False
        self.use_property_decorate = False
        self.alignment = "EXPAND"
        self.scale_x = self.scale_y = 1.0
        self.active = True
        self.operator_context = "INVOKE_DEFAULT"
        self.emboss = "NORMAL"

    # the sub-layouts ---------------------------------------------------------------------------------------
    @property
    def enabled(self):
        return self._node.enabled

    @enabled.setter
    def enabled(self, value):
        self._node.enabled = bool(value)

    def _child(self, kind, factor=0.0):
        node = Node(kind, factor, enabled=self._node.enabled)
        self._node.children.append(node)
        return MeasuringLayout(node, self._checks)

    def row(self, align=False, heading="", **kwargs):
        if heading:
            self._node.children.append(Item("label", heading))
        return self._child("row")

    def column(self, align=False, heading="", **kwargs):
        if heading:
            self._node.children.append(Item("label", heading))
        return self._child("column")

    def box(self):
        return self._child("box")

    def split(self, factor=0.0, align=False):
        return self._child("split", factor)

    def grid_flow(self, **kwargs):
        return self._child("column")

    # the items -------------------------------------------------------------------------------------------
    def _add(self, item: Item):
        item.enabled = item.enabled and self._node.enabled
        self._node.children.append(item)
        return item

    def label(self, text="", icon="NONE", **kwargs):
        self._add(Item("label", text, _icon(icon), fixed=not text))

    def separator(self, **kwargs):
        self._add(Item("separator"))

    def progress(self, factor=0.0, text="", **kwargs):
        self._add(Item("progress", text))

    def operator(self, idname, text=None, icon="NONE", **kwargs):
        if self._checks:
            self._checks.operator(idname)
        label = self._checks.operator_label(idname) if text is None and self._checks else (text or "")
        self._add(Item("operator", label, _icon(icon), fixed=not label))
        return SimpleNamespace()

    def operator_menu_enum(self, idname, prop, text=None, icon="NONE", **kwargs):
        if self._checks:
            self._checks.operator(idname, prop)
        self._add(Item("operator", text or "", _icon(icon), fixed=not text))

    def prop(self, data, name, text=None, icon="NONE", expand=False, toggle=False, emboss=True, **kwargs):
        if self._checks:
            self._checks.prop(data, name)
        parts, icon_only = prop_parts(data, name, text, icon, expand, toggle)
        self._add(Item("prop", parts=tuple(parts), fixed=icon_only, count=len(parts) if expand else 1))

    def prop_search(self, data, name, search_data, search_name, text=None, icon="NONE", **kwargs):
        if self._checks:
            self._checks.prop(data, name)
        label = data.bl_rna.properties[name].name if text is None else text
        parts = ([("prop label", label, False)] if label else []) + [("text field", "", True)]
        self._add(Item("prop", parts=tuple(parts)))

    def template_list(self, *args, **kwargs):
        self._add(Item("opaque", "list"))

    # the widths -----------------------------------------------------------------------------------------
    def resolve(self, width: float, scale: float, measure) -> list[Line]:
        """Every piece of text with the width its place leaves it, in drawing order (rows numbered)."""
        lines: list[Line] = []
        _Resolver(scale, measure, lines).node(self._node, 0.0, width, vertical=True)
        return lines


class _Resolver:
    def __init__(self, scale, measure, lines):
        self.s, self.measure, self.lines, self.row = scale, measure, lines, 0

    def node(self, node: Node, x: float, width: float, vertical: bool):
        if node.kind == "box":
            pad = text_fit.BOX_SPACE * self.s
            for child in node.children:
                self.child(child, x + pad, width - 2 * pad, vertical=True)
            return
        if node.kind in ("column", "root") or (vertical and node.kind not in ("row", "split")):
            for child in node.children:  # the panel's own layout lays an expanded enum across (local direction)
                across = node.kind == "root" and isinstance(child, Item) and child.count > 1
                self.child(child, x, width, vertical=not across)
            return
        # a row or a split: one line of the panel shared across
        children = node.children
        if not children:
            return
        widths = self._shares(node, width)
        start_row = self.row
        rows_used = 0
        for child, (cx, cw) in zip(children, widths):
            self.row = start_row
            self.child(child, x + cx, cw, vertical=False)
            rows_used = max(rows_used, self.row - start_row)
        self.row = start_row + max(1, rows_used)

    def _shares(self, node: Node, width: float):
        """(x, width) of each item across a row or a split."""
        children = node.children
        if node.kind == "split" and node.factor > 0:
            first = width * node.factor
            rest = (width - first) / max(1, len(children) - 1)
            out, cx = [], 0.0
            for i, _ in enumerate(children):
                w = first if i == 0 else rest
                out.append((cx, w))
                cx += w
            return out
        weights = [self._weight(c) for c in children]
        fixed = sum(w for w, is_fixed in weights if is_fixed)
        flexible = sum(w for w, is_fixed in weights if not is_fixed)
        left = max(0.0, width - fixed)
        out, cx = [], 0.0
        for w, is_fixed in weights:
            cw = w if is_fixed else (left * w / flexible if flexible else 0.0)
            out.append((cx, cw))
            cx += cw
        return out

    def _weight(self, child):
        """(weight, fixed): an icon-only button is one unit; an expanded enum counts its items."""
        if isinstance(child, Item) and child.fixed:
            return U * self.s, True
        if isinstance(child, Item) and child.kind == "separator":
            return 0.5 * U * self.s, True
        if isinstance(child, Item):
            return float(child.count), False
        return 1.0, False

    def child(self, child, x, width, vertical):
        if isinstance(child, Node):
            self.node(child, x, width, vertical)
            return
        self.item(child, x, width, vertical)

    def _line(self, kind, text, room, width, x, icon, enabled):
        self.lines.append(Line(kind, text, self.measure(text) if text else 0.0, room, width, icon, enabled, x,
                               self.row))

    def item(self, item: Item, x, width, vertical):
        s = self.s
        if item.kind == "separator":
            self.row += 1 if vertical else 0
            return
        if item.kind == "label":
            self._line("label", item.text, text_fit.label_room(width, s, item.icon), width, x, item.icon,
                       item.enabled)
        elif item.kind == "operator":
            room = width - s * (2 * text_fit.CLIP_MARGIN + (text_fit.ICON if item.icon else 0.0))
            self._line("operator", item.text, room, width, x, item.icon, item.enabled)
        elif item.kind == "progress":
            self._line("progress", item.text, width - 2 * s * text_fit.CLIP_MARGIN, width, x, False, item.enabled)
        elif item.kind == "opaque":
            self._line("opaque", "", width, width, x, False, item.enabled)
        elif item.kind == "prop":
            self.prop(item, x, width, vertical)
            return
        self.row += 1

    def prop(self, item: Item, x, width, vertical):
        s = self.s
        parts = item.parts
        if parts and parts[0][0] == "enum item":  # expanded: across a row, down a column
            if vertical:
                for _, text, _ in parts:
                    self._line("enum item", text, text_fit.label_room(width, s, False), width, x, False,
                               item.enabled)
                    self.row += 1
                return
            w = width / len(parts)
            for i, (_, text, _) in enumerate(parts):
                self._line("enum item", text, w - 2 * s * text_fit.CLIP_MARGIN, w, x + i * w, False, item.enabled)
            self.row += 1
            return
        if parts and parts[0][0] == "prop label":  # a third for the name, the rest for the field
            label_w = width / 3
            self._line("prop label", parts[0][1], text_fit.label_room(label_w, s, False), label_w, x, False,
                       item.enabled)
            x, width, parts = x + label_w, width - label_w, parts[1:]
        for kind, text, icon in parts:
            if kind == "enum value":  # the menu's arrow at the right
                room = text_fit.label_room(width, s, icon) - s * text_fit.ICON
            elif kind == "pointer value":
                room = text_fit.label_room(width, s, True) - s * text_fit.ICON  # the object's icon, the X
            elif kind == "number":
                room = width - s * (2 * text_fit.TEXT_PADDING + text_fit.CLIP_MARGIN + (text_fit.ICON if icon else 0))
            elif kind in ("check box", "toggle"):
                room = text_fit.label_room(width, s, True)
            else:  # text field, opaque: not measured
                text, room = "", width
            self._line(kind, text, room, width, x, icon, item.enabled)
        self.row += 1


class RNAChecks:
    """Refuses a property or an operator that does not exist (a panel typo would fail only in Blender)."""

    def __init__(self, ops):
        self.ops = ops

    def _op(self, idname):
        module, _, name = idname.partition(".")
        return getattr(getattr(self.ops, module), name)

    def operator(self, idname, prop=None):
        module, _, name = idname.partition(".")
        if not hasattr(getattr(self.ops, module), name):
            raise AssertionError(f"no operator {idname}")
        if prop is not None and prop not in self._op(idname).get_rna_type().properties:
            raise AssertionError(f"no property {prop} on operator {idname}")

    def operator_label(self, idname) -> str:
        return self._op(idname).get_rna_type().name

    def prop(self, data, name):
        if name not in data.bl_rna.properties:
            raise AssertionError(f"no property {name} on {data}")
