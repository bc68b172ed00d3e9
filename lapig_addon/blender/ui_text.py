"""The sidebar's width, UI scale and font metrics, for services/panel/text_fit: what a panel's line can hold."""
from __future__ import annotations

from ..services.panel import text_fit


def ui_scale(context) -> float:
    """Blender's UI scale with the display's DPI (preferences.system.ui_scale; 0 in background mode, where
    the view's setting is all there is)."""
    prefs = getattr(context, "preferences", None)
    if prefs is None:
        return 1.0
    return float(getattr(prefs.system, "ui_scale", 0.0) or getattr(prefs.view, "ui_scale", 1.0) or 1.0)


def ui_points(context) -> float:
    """The theme's widget font size (the labels' and buttons')."""
    try:
        return float(context.preferences.ui_styles[0].widget.points)
    except (AttributeError, IndexError, TypeError):
        return text_fit.UI_POINTS


def blf_measure(points: float):
    """A text's width in pixels with Blender's UI font (font 0) at `points` (scaled); the average character's
    width where blf cannot measure (no bpy)."""
    try:
        import blf
    except ImportError:
        return text_fit.average_measure(points)
    widths: dict = {}

    def measure(text: str) -> float:
        width = widths.get(text)
        if width is None:
            blf.size(0, points)  # another draw may have changed font 0's size since the last call
            width = widths[text] = float(blf.dimensions(0, text)[0])
        return width

    return measure


def fit_for(context) -> text_fit.TextFit:
    """The lines of the panel being drawn: the region's width (a wide sidebar when there is none: a script's or
    a test's context) at the UI scale, measured with Blender's font."""
    scale = ui_scale(context)
    region = getattr(context, "region", None)
    width = getattr(region, "width", None) if region is not None else None
    points = ui_points(context) * scale
    return text_fit.fit_for(width, scale, blf_measure(points), points=points)
