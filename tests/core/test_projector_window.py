"""The projector window (lapig_core.rig.projector_window and its helper process window_process).

The display tests run a virtual X server with two monitors side by side (640x480 at the left, 800x600
at its right), open the window on the second by index and by name, and compare a screenshot of the
root window (xwd, read here) with the frame pixel for pixel.

The server is Xvnc (TigerVNC), an Xvfb with RandR outputs added when a VNC client asks for a screen
layout (the test asks, over the VNC protocol on a Unix socket): SDL2 sees displays as RandR outputs,
and Xvfb has one output per X screen, so two Xvfb screens are two X screens (":N.0", ":N.1"), on which
SDL2 puts a full-screen window on screen 0 whatever display it was given. One screen with two outputs
is what a desktop with a projector plugged in looks like.

CI installs the tools with
    apt-get install -y --no-install-recommends tigervnc-standalone-server x11-apps xdotool
(.ci/run); where one is missing the display tests skip and say which.
"""
from __future__ import annotations

import importlib.util
import io
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from lapig.tools import virtual_screens
from lapig.tools.virtual_screens import missing_tools, region, screenshot
from lapig.lapig_core.rig import RigError
from lapig.lapig_core.rig.projector_window import CLOSED_MESSAGE, ProjectorWindow, list_displays
from lapig.lapig_core.rig.window_process import (DisplayChoiceError, ProtocolError, choose_display, encode_message,
                                           read_message)


# ---------------------------------------------------------------- without a display

FAKE_DISPLAYS = [{"index": 0, "name": "DELL U2720Q", "x": 0, "y": 0, "width": 3840, "height": 2160},
                 {"index": 1, "name": "EPSON PJ", "x": 3840, "y": 0, "width": 1920, "height": 1080},
                 {"index": 2, "name": "EPSON PJ 2", "x": 5760, "y": 0, "width": 1920, "height": 1080}]


def test_a_display_is_chosen_by_index_or_by_a_part_of_its_name():
    assert choose_display(FAKE_DISPLAYS, 1)["name"] == "EPSON PJ"
    assert choose_display(FAKE_DISPLAYS, "2")["name"] == "EPSON PJ 2"
    assert choose_display(FAKE_DISPLAYS, "dell")["index"] == 0
    assert choose_display(FAKE_DISPLAYS, "epson pj")["index"] == 1  # a whole name wins over parts of others
    with pytest.raises(DisplayChoiceError, match=r"in the names of displays 1, 2: give the index"):
        choose_display(FAKE_DISPLAYS, "epson")
    with pytest.raises(DisplayChoiceError, match=r"no display's name contains 'BenQ'; the displays: "
                                                 r"0 'DELL U2720Q' 3840x2160 at \(0, 0\), 1 'EPSON PJ'"):
        choose_display(FAKE_DISPLAYS, "BenQ")
    with pytest.raises(DisplayChoiceError, match=r"there is no display 3 \(3 connected\)"):
        choose_display(FAKE_DISPLAYS, 3)
    for wrong in (True, None, 1.0, " "):
        with pytest.raises(DisplayChoiceError):
            choose_display(FAKE_DISPLAYS, wrong)


def test_a_message_is_a_json_line_and_its_bytes():
    payload = bytes(range(256)) * 3
    stream = io.BytesIO(encode_message({"cmd": "show", "width": 16, "height": 16}, len(payload)) + payload
                        + encode_message({"cmd": "close"}))
    header, data = read_message(stream)
    assert header == {"cmd": "show", "width": 16, "height": 16, "nbytes": 768} and bytes(data) == payload
    assert read_message(stream) == ({"cmd": "close"}, bytearray())
    assert read_message(stream) is None
    with pytest.raises(ProtocolError, match="ended 8 bytes before"):
        read_message(io.BytesIO(encode_message({"cmd": "show"}, 10) + b"ab"))
    with pytest.raises(ProtocolError, match="not JSON"):
        read_message(io.BytesIO(b"hello\n"))


def test_a_helper_that_does_not_answer_is_killed_and_said(tmp_path):
    silent = tmp_path / "silent-python"
    silent.write_text(f"#!/bin/sh\necho 'stuck before SDL' >&2\n"
                      f"exec '{sys.executable}' -c 'import time; time.sleep(60)'\n")
    silent.chmod(0o755)
    started = time.monotonic()
    with pytest.raises(RigError, match=r"did not open on display 'EPSON'.*did not start within 1 s; its stderr: "
                                       r"stuck before SDL"):
        ProjectorWindow("EPSON", python=str(silent), start_timeout_s=1.0)
    assert time.monotonic() - started < 8


FAKE_HELPER = """
import sys  # the helper process: lapig_core is top-level on its path (ProjectorWindow sets it)
from lapig_core.rig.window_process import encode_message, read_message

def answer(header):
    sys.stdout.buffer.write(encode_message(header))
    sys.stdout.buffer.flush()

answer({"event": "ready", "sdl": "none: a fake helper"})
frames = 0
while True:
    message = read_message(sys.stdin.buffer)
    if message is None or message[0]["cmd"] == "close":
        break
    if message[0]["cmd"] == "open":
        answer({"ok": True, "display": {"index": 1, "name": "fake"}, "size": [16, 8]})
    else:
        frames += 1
        answer({"ok": True, "frame": frames})
"""


def test_frames_are_sent_by_one_thread_per_window_not_one_per_frame(tmp_path, monkeypatch):
    helper = tmp_path / "fake_helper.py"
    helper.write_text(FAKE_HELPER)
    python = tmp_path / "fake-python"
    python.write_text(f"#!/bin/sh\nexec '{sys.executable}' '{helper}'\n")
    python.chmod(0o755)
    started, start = [], threading.Thread.start

    def counted_start(thread):
        started.append(thread.name)
        start(thread)

    with ProjectorWindow(1, python=str(python)) as window:
        monkeypatch.setattr(threading.Thread, "start", counted_start)
        for i in range(50):
            window.show(pattern(16, 8, seed=i))
        monkeypatch.undo()
        assert window.describe()["frames_shown"] == 50
    assert started == []  # before: a timer thread per frame
    deadline = time.monotonic() + 10
    while _writers() and time.monotonic() < deadline:  # the window's own writer ends with its helper
        time.sleep(0.01)
    assert not _writers()


def _writers():
    return [t for t in threading.enumerate() if t.name == "lapig-window-requests"]


# The helper's Python imports this first (PYTHONPATH leads to it): the system's library search finds no SDL2, as on
# a machine without it. An empty PYSDL2_DLL_PATH alone is not enough: PySDL2 then asks ctypes.util.find_library,
# which finds a system libSDL2 where one is installed (ffmpeg brings it).
NO_SYSTEM_SDL2 = """
import ctypes.util
_find_library = ctypes.util.find_library
ctypes.util.find_library = lambda name: None if name.lower().startswith("sdl2") else _find_library(name)
"""


@pytest.mark.skipif(importlib.util.find_spec("sdl2") is None, reason="needs PySDL2 (pip install pysdl2 pysdl2-dll)")
def test_a_helper_without_sdl2_says_what_to_install(tmp_path):
    (tmp_path / "sitecustomize.py").write_text(NO_SYSTEM_SDL2)
    env = dict(os.environ, PYSDL2_DLL_PATH=str(tmp_path),  # no SDL2 library there, so pysdl2-dll's is not used
               PYTHONPATH=os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")])))
    with pytest.raises(RigError, match=r"did not open on display '1': PySDL2 or its SDL2 library is missing .*"
                                       r"pysdl2 and pysdl2-dll"):
        ProjectorWindow(1, env=env)


# ---------------------------------------------------------------- the virtual two-monitor X server

@pytest.fixture(scope="module")
def two_monitors():
    """DISPLAY of an Xvnc with MONITORS side by side on one screen, black root (tools/virtual_screens)."""
    if missing_tools():
        pytest.skip("needs " + "; ".join(missing_tools()))
    with virtual_screens.two_monitors() as env:
        yield env


def pattern(width, height, seed=0):
    return np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)


@pytest.mark.skipif(importlib.util.find_spec("sdl2") is None, reason="needs PySDL2")
def test_without_a_screen_no_display_is_listed_and_the_reason_is_said():
    """With no desktop SDL falls back to its offscreen driver, whose one 'display' is not a screen: the
    listing refuses it as the window does, instead of offering display 0."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")}
    with pytest.raises(RigError) as refused:
        list_displays(env=env)
    assert str(refused.value).startswith("the displays could not be listed: there is no screen here"), refused.value


@pytest.mark.display
def test_the_helper_lists_both_monitors(two_monitors):
    displays = list_displays(env=two_monitors)
    assert [(d["index"], d["name"], d["x"], d["y"], d["width"], d["height"]) for d in displays] == [
        (0, "VNC-0", 0, 0, 640, 480), (1, "VNC-1", 640, 0, 800, 600)]


@pytest.mark.display
@pytest.mark.parametrize("display", [1, "vnc-1"], ids=["by index", "by name"])
def test_a_frame_is_on_the_chosen_monitor_pixel_for_pixel(two_monitors, display):
    frame = pattern(800, 600)
    with ProjectorWindow(display, env=two_monitors) as window:
        assert window.size == (800, 600)
        before = time.perf_counter()
        shown = window.show(frame)
        assert before < shown <= time.perf_counter()
        image = screenshot(two_monitors)
        info = window.describe()
    assert np.array_equal(region(image, 1), frame)
    assert not region(image, 0).any()  # the other monitor shows nothing of it: black root
    assert info["display"] == {"index": 1, "name": "VNC-1", "x": 640, "y": 0, "width": 800, "height": 600,
                               "refresh_hz": 60}
    assert info["size"] == [800, 600] and info["video_driver"] == "x11" and info["framebuffer"] == "software"
    assert info["sdl_version"].count(".") == 2 and info["frames_shown"] == 1


@pytest.mark.display
def test_a_smaller_frame_is_drawn_at_the_top_left_on_black_and_a_larger_one_is_refused(two_monitors):
    with ProjectorWindow(0, env=two_monitors) as window:
        assert window.size == (640, 480)
        window.show(pattern(640, 480, seed=1))
        small = pattern(300, 200, seed=2)
        window.show(small)
        on_screen = region(screenshot(two_monitors), 0)
        assert np.array_equal(on_screen[:200, :300], small)
        on_screen[:200, :300] = 0
        assert not on_screen.any()  # the rest of the first frame is gone, black
        with pytest.raises(RigError, match=r"the frame is 641x480 but the projector's display 'VNC-0' is 640x480"):
            window.show(pattern(641, 480))
        window._size = (4000, 4000)  # past the client's check: the helper refuses it too, and stays up
        with pytest.raises(RigError, match=r"the frame is 640x481 but display 0 'VNC-0' shows 640x480"):
            window.show(pattern(640, 481))
        window.show(small)
        assert window.is_open
        with pytest.raises(RigError, match=r"uint8 RGB \(H, W, 3\), not float32"):
            window.show(np.zeros((10, 10, 3), np.float32))


@pytest.mark.display
def test_a_missing_display_is_refused_with_the_names_of_those_there(two_monitors):
    with pytest.raises(RigError, match=r"did not open on display 'BenQ': no display's name contains 'BenQ'; "
                                       r"the displays: 0 'VNC-0' 640x480 at \(0, 0\), 1 'VNC-1' 800x600 at \(640, 0\)"):
        ProjectorWindow("BenQ", env=two_monitors)
    with pytest.raises(RigError, match=r"there is no display 2 \(2 connected\)"):
        ProjectorWindow(2, env=two_monitors)
    with pytest.raises(RigError, match=r"'vnc' is in the names of displays 0, 1"):
        ProjectorWindow("vnc", env=two_monitors)


@pytest.mark.display
def test_esc_closes_the_window_and_the_next_call_says_so(two_monitors):
    window = ProjectorWindow(1, env=two_monitors)
    try:
        window.show(pattern(800, 600))
        info = window.describe()
        press = subprocess.run(["xdotool", "windowfocus", "--sync", str(info["x11_window"]), "key", "Escape"],
                               env=two_monitors, capture_output=True, text=True, timeout=30)
        assert press.returncode == 0, press.stderr
        deadline = time.monotonic() + 10
        with pytest.raises(RigError, match=r"^the projector window was closed \(Esc or the window's close button\)$"):
            while time.monotonic() < deadline:
                window.show(pattern(800, 600))
                time.sleep(0.05)
        assert not window.is_open
        with pytest.raises(RigError, match="closed"):
            window.show(pattern(8, 8))
        assert CLOSED_MESSAGE.startswith("the projector window was closed")
    finally:
        window.close()
    _assert_gone(info["helper_pid"])


@pytest.mark.display
def test_a_worker_thread_drives_the_window_and_close_ends_the_helper(two_monitors):
    results = {}

    def worker():
        try:
            with ProjectorWindow("VNC-1", env=two_monitors) as window:
                results["times"] = [window.show(pattern(800, 600, seed=i)) for i in range(3)]
                results["pid"] = window.describe()["helper_pid"]
                results["image"] = screenshot(two_monitors)
        except Exception as exc:  # noqa: BLE001  (handed to the test's thread)
            results["error"] = exc

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join(60)
    assert "error" not in results, results.get("error")
    assert results["times"] == sorted(results["times"])
    assert np.array_equal(region(results["image"], 1), pattern(800, 600, seed=2))
    _assert_gone(results["pid"])
    assert not region(screenshot(two_monitors), 1).any()  # the window is gone from the screen


@pytest.mark.display
def test_a_window_dropped_without_close_ends_its_helper(two_monitors):
    import gc

    window = ProjectorWindow(0, env=two_monitors)
    pid = window.describe()["helper_pid"]
    del window
    gc.collect()
    _assert_gone(pid)


def _assert_gone(pid) -> None:
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        try:  # a zombie until its parent waits: reaped by close(), so only a live one fails
            with open(f"/proc/{pid}/stat") as f:
                if f.read().split(")")[-1].split()[0] == "Z":
                    return
        except OSError:
            return
        time.sleep(0.05)
    raise AssertionError(f"the helper {pid} is still running")


@pytest.mark.display
def test_the_helper_runs_with_a_python_that_has_neither_sdl2_nor_this_venv(two_monitors):
    """As in Blender: the helper runs with Blender's Python, which finds PySDL2 only through the path the
    client hands it (the extension's wheels' site-packages)."""
    bare = getattr(sys, "_base_executable", None)
    if not bare or sys.prefix == sys.base_prefix:
        pytest.skip("not in a virtual environment: no bare Python to run the helper with")
    probe = subprocess.run([bare, "-c", "import sdl2"], capture_output=True, env={"PATH": os.defpath})
    assert probe.returncode != 0, "the bare Python has PySDL2 of its own: the test would prove nothing"
    frame = pattern(800, 600, seed=5)
    with ProjectorWindow("VNC-1", python=bare, env=two_monitors) as window:
        window.show(frame)
        image = screenshot(two_monitors)
    assert np.array_equal(region(image, 1), frame)
