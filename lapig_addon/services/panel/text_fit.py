"""How much text fits on a line of a sidebar panel, and lines that fit (no bpy).

Blender clips a label that is wider than its button in the middle or at its end ("Surface ...",
"Falls back to 'styl...dule named 'torch'"), whatever the sidebar's width. A panel wraps its sentences
with `TextFit.wrap` at the width Blender gives the line, measured with Blender's own font metrics
(blender/ui_text builds the measure with blf), and shows a path by its tail (`TextFit.tail`).

The widths follow Blender's panel layout (source/blender/editors: interface_intern.hh, area.cc,
interface_widgets.cc), in pixels at UI scale 1, times the UI scale:
- the region's width less the category tabs (UI_PANEL_CATEGORY_MARGIN_WIDTH: one widget unit), the panel's
  margins (UI_PANEL_MARGIN_X: 0.4 unit each side) and the layout's space (style panelspace: 8 each side);
- a box's content: less the box's space (style boxspace: 5) each side;
- a label's text: less the text padding (UI_TEXT_MARGIN_X: 0.4 unit) and the clip margin (0.25 unit), and
  an icon's unit when it has one.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

UNIT = 20.0  # U.widget_unit at UI scale 1
TABS = 1.0 * UNIT  # the sidebar's category tabs (Item, Tool, View, LAPIG)
PANEL_MARGIN = 0.4 * UNIT  # each side
PANEL_SPACE = 8.0  # each side
BOX_SPACE = 5.0  # each side
TEXT_PADDING = 0.4 * UNIT  # left-aligned text starts this far into its button
CLIP_MARGIN = 0.25 * UNIT  # Blender clips text that comes closer than this to the button's end
ICON = 1.0 * UNIT  # an icon and its padding
UI_POINTS = 11.0  # the theme's widget font size (preferences.ui_styles[0].widget.points)
SIDEBAR_WIDTH = 220.0  # UI_SIDEBAR_PANEL_WIDTH: the sidebar's width when first opened, at scale 1
NO_REGION_WIDTH = 500.0  # a panel drawn without a region (a script, a test): no sidebar to fit, a wide one
ELLIPSIS = "\u2026"
AVERAGE_CHAR = 0.55  # an average character's width in font sizes, where no font metrics are at hand


def average_measure(points: float) -> Callable[[str], float]:
    """A text's width in pixels at font size `points`, without font metrics: a little wider than Blender's
    font on average, so what it wraps fits."""
    return lambda text: len(text) * points * AVERAGE_CHAR


def content_width(region_width: float, scale: float, tabs: bool = True) -> float:
    """The width a panel's layout gets in a sidebar of `region_width` pixels at UI scale `scale`."""
    return region_width - scale * ((TABS if tabs else 0.0) + 2 * PANEL_MARGIN + 2 * PANEL_SPACE)


def label_room(width: float, scale: float, icon: bool) -> float:
    """The width a label of `width` pixels leaves its text."""
    return width - scale * (TEXT_PADDING + CLIP_MARGIN + (ICON if icon else 0.0))


@dataclass(frozen=True)
class TextFit:
    """The lines of one layout: `width` pixels wide at UI scale `scale`; `measure(text)` is a text's width in
    pixels at that scale."""
    width: float
    scale: float
    measure: Callable[[str], float]

    def boxed(self, depth: int = 1) -> "TextFit":
        """The lines of a box inside this layout (`depth` boxes deep)."""
        return TextFit(self.width - depth * 2 * BOX_SPACE * self.scale, self.scale, self.measure)

    def share(self, parts: int) -> "TextFit":
        """The lines of one of `parts` equal columns of a row (a split) of this layout."""
        return TextFit(self.width / max(1, parts), self.scale, self.measure)

    def beside(self, buttons: int) -> "TextFit":
        """The lines of a row that also holds `buttons` icon-only buttons (a unit each)."""
        return TextFit(self.width - buttons * ICON * self.scale, self.scale, self.measure)

    def room(self, icon: bool = True) -> float:
        return label_room(self.width, self.scale, icon)

    def fits(self, text: str, icon: bool = True) -> bool:
        return self.measure(text) <= self.room(icon)

    def wrap(self, text: str, icon: bool = True, first_icon: bool | None = None) -> list[str]:
        """`text` in lines that fit a label each (with an icon, or without one; the first line's own: `first_icon`,
        as `icon` by default), broken between words; a word wider than a line (a path, a long name) keeps its
        tail. Blank text: one blank line."""
        first_icon = icon if first_icon is None else first_icon
        lines: list[str] = []
        line = ""
        for word in text.split():
            with_icon = first_icon if not lines else icon
            candidate = f"{line} {word}" if line else word
            if self.measure(candidate) <= self.room(with_icon):
                line = candidate
                continue
            if line:
                lines.append(line)
                with_icon = icon
            line = word if self.measure(word) <= self.room(with_icon) else self.tail(word, with_icon)
        lines.append(line)
        return lines

    def head(self, text: str, icon: bool = True) -> str:
        """`text` whole where it fits, else its start and an ellipsis ("2. Projector.0..."): a name on a row
        of its buttons."""
        room = self.room(icon)
        if self.measure(text) <= room:
            return text
        for end in range(len(text) - 1, 0, -1):
            candidate = text[:end].rstrip() + ELLIPSIS
            if self.measure(candidate) <= room:
                return candidate
        return ELLIPSIS

    def tail(self, text: str, icon: bool = True, keep: str = "", sep: str = "/\\") -> str:
        """`text` whole where it fits, else its end after an ellipsis: a path from a folder boundary on
        ("…/captures/wall_lapig"), else its last characters. `keep`: a start of `text` that stays ("Data: ")."""
        room = self.room(icon)
        if self.measure(text) <= room:
            return text
        head, rest = (keep, text[len(keep):]) if keep and text.startswith(keep) else ("", text)
        cuts = [i for i, ch in enumerate(rest) if ch in sep]
        for i in cuts:  # the longest tail that starts at a folder boundary
            candidate = head + ELLIPSIS + rest[i:]
            if self.measure(candidate) <= room:
                return candidate
        for i in range(1, len(rest)):
            candidate = head + ELLIPSIS + rest[i:]
            if self.measure(candidate) <= room:
                return candidate
        return head + ELLIPSIS if self.measure(head + ELLIPSIS) <= room else ELLIPSIS


def fit_for(region_width: float | None, scale: float, measure: Callable[[str], float] | None = None,
            points: float = UI_POINTS) -> TextFit:
    """The lines of a sidebar panel: `region_width` pixels (None: no region, a wide sidebar) at UI scale
    `scale`, measured with `measure` (None: the average character's width)."""
    scale = scale if scale and scale > 0 else 1.0
    if region_width is None or region_width <= 0:
        region_width = NO_REGION_WIDTH * scale
    return TextFit(content_width(region_width, scale), scale, measure or average_measure(points * scale))
