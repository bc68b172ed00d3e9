"""Lines that fit a sidebar panel (services/panel/text_fit), measured here with a fixed width per character."""
import importlib

import pytest

CHAR = 6.0  # pixels per character at UI scale 1, about Blender's 11-point font


@pytest.fixture
def text_fit():
    return importlib.import_module("lapig.lapig_addon.services.panel.text_fit")


def fit_at(text_fit, region_width, scale=1.0):
    return text_fit.fit_for(region_width, scale, lambda text: len(text) * CHAR * scale)


def test_the_layout_width_is_the_region_less_the_tabs_and_margins_at_the_ui_scale(text_fit):
    assert text_fit.content_width(250, 1.0) == 250 - 20 - 16 - 16
    assert text_fit.content_width(250, 2.0) == 250 - 2 * 52
    assert fit_at(text_fit, 250).room(icon=True) == 198 - 8 - 5 - 20  # text padding, clip margin, icon
    assert fit_at(text_fit, 250).boxed().width == 198 - 10
    assert fit_at(text_fit, 250).beside(1).width == 198 - 20
    # no region (a script's context): no sidebar to fit, a wide one
    assert text_fit.fit_for(None, 1.0).width == text_fit.content_width(text_fit.NO_REGION_WIDTH, 1.0)


@pytest.mark.parametrize("width, scale", [(220, 1.0), (250, 1.0), (350, 1.0), (500, 1.0), (250, 1.25), (500, 2.0)])
def test_wrapped_lines_fit_and_keep_every_word(text_fit, width, scale):
    fit = fit_at(text_fit, width, scale)
    text = "First look: classical model (fitted in 0.1 s); Train for the networks"
    for icon in (True, False):
        lines = fit.wrap(text, icon=icon)
        assert all(fit.fits(line, icon=icon) for line in lines)
        assert " ".join(lines) == text
    assert len(fit_at(text_fit, 220).wrap(text)) > len(fit_at(text_fit, 500).wrap(text))  # narrower: more lines
    # a first line without an icon, the next ones indented an icon's width
    lines = fit.wrap(text, icon=True, first_icon=False)
    assert fit.fits(lines[0], icon=False) and all(fit.fits(line, icon=True) for line in lines[1:])
    assert " ".join(lines) == text


def test_a_word_wider_than_the_line_keeps_its_tail(text_fit):
    fit = fit_at(text_fit, 250)
    path = "/home/artist/projects/museum/wall_lapig/Wall/capture_0001"
    lines = fit.wrap("Captured into " + path)
    assert lines[0] == "Captured into" and lines[-1] == "\u2026/Wall/capture_0001"
    assert all(fit.fits(line) for line in lines)


def test_a_path_shows_its_tail_from_a_folder_boundary_and_keeps_its_prefix(text_fit):
    fit = fit_at(text_fit, 250)
    path = "/home/artist/projects/museum/wall_lapig"
    assert fit.tail("/tmp/a") == "/tmp/a"  # fits: whole
    tail = fit.tail("Data: " + path, keep="Data: ")
    assert tail.startswith("Data: \u2026/") and tail.endswith("/wall_lapig") and fit.fits(tail)
    assert path.endswith(tail[len("Data: \u2026"):])
    # no folder boundary near the end: its last characters
    word = "x" * 80
    assert fit.tail(word) == "\u2026" + "x" * (int(fit.room() // CHAR) - 1)


def test_without_font_metrics_the_average_character_is_a_little_wide(text_fit):
    fit = text_fit.fit_for(250, 1.0)  # no measure: the average character's width
    assert fit.measure("abcd") == pytest.approx(4 * 11 * text_fit.AVERAGE_CHAR)
    assert all(fit.fits(line) for line in fit.wrap("Install torch (see the add-on preferences) " * 3))


def test_a_name_beside_buttons_keeps_its_start(text_fit):
    fit = fit_at(text_fit, 250).beside(1)
    assert fit.head("2. Projector") == "2. Projector"
    name = fit.head("2. " + "Projector " * 10)
    assert name.startswith("2. Projector") and name.endswith("\u2026") and fit.fits(name)
