# SPDX-License-Identifier: GPL-3.0-or-later
"""The projector window's helper process: `python -m lapig_core.rig.window_process`.

A Blender add-on cannot put a window on a chosen monitor (Window.x/y are read-only and full screen
toggles wherever the window is), so the projector output is this small process, started by
`projector_window.ProjectorWindow` with the same Python (in Blender: Blender's own) and driven over its
stdin and stdout. It imports the standard library and PySDL2 only (numpy is not needed), so it runs
under any Blender's Python.

Why SDL2 (through PySDL2, ctypes bindings in pure Python, with the SDL2 binaries of pysdl2-dll):
- a window goes on a display chosen by index, placed by SDL_GetDisplayBounds, and displays are named by
  SDL_GetDisplayName (a case-insensitive part of the name chooses one);
- SDL_WINDOW_FULLSCREEN_DESKTOP covers the display at its current mode: no mode switch;
- the window surface (SDL_GetWindowSurface / SDL_UpdateWindowSurface) is a software framebuffer (X11:
  XShm or XPutImage, Windows: a GDI DIB): the frame's pixels reach the display 1:1, with no OpenGL, no
  scaling and no colour management on the way (macOS has no software framebuffer: SDL draws the surface
  1:1 as a texture there);
- Windows: the process is made per-monitor DPI aware ("permonitorv2"), so a display at 150% is still
  its real pixels;
- Linux on Wayland with XWayland (WAYLAND_DISPLAY and DISPLAY both set): SDL_VIDEODRIVER=x11, where
  windows have global positions and full screen on the display the window is on is the window manager's
  ordinary _NET_WM_STATE_FULLSCREEN (unless the user set SDL_VIDEODRIVER);
- a full-screen window stays up when another window (Blender's) takes the focus
  (SDL_VIDEO_MINIMIZE_ON_FOCUS_LOSS=0).

The window: borderless, full screen on the chosen display, the cursor hidden. A frame is drawn 1:1 at
the top-left on black; a frame larger than the display is refused with both sizes.

The protocol, both ways: a message is one JSON line (UTF-8, ending in a newline) and then exactly
`nbytes` raw bytes (0 when the header has no `nbytes`).
  requests   {"cmd": "displays"}                 -> {"ok": true, "displays": [{index, name, x, y, width,
                                                     height, mode_width, mode_height, refresh_hz}]}
             {"cmd": "open", "display": 1 | "DELL"} -> {"ok": true, "display": {...}, "size": [w, h], ...}
             {"cmd": "show", "width": w, "height": h, "nbytes": w*h*3} + uint8 RGB rows
                                                 -> {"ok": true, "frame": n} once SDL_UpdateWindowSurface
                                                    returned
             {"cmd": "load", "width": w, "height": h, "nbytes": w*h*3} + rows
                                                 -> {"ok": true}: the frame drawn into the window's surface,
                                                    not yet on screen
             {"cmd": "present"}                  -> {"ok": true, "frame": n, "t": time.monotonic()} once
                                                    SDL_UpdateWindowSurface returned (several windows load,
                                                    then present together: rig/frame_lock)
             {"cmd": "close"}                    -> {"ok": true}, then the process exits
  a refused request                              -> {"ok": false, "error": "..."}
  events     {"event": "ready", "sdl": "2.32.10", "driver": "x11", ...} once, first
             {"event": "closed", "message": "closed by user"}: Esc or the window's close button; the
                                                    process exits (status 0)
             {"event": "error", "message": "..."}: the process cannot go on and exits (status 1)
stdin's end (the add-on went away) closes the window and ends the process.
"""
from __future__ import annotations

import json
import os
import queue
import sys
import threading

CLOSED_BY_USER = "closed by user"
MAX_HEADER_BYTES = 65536
MAX_FRAME_PIXELS = 16384 * 16384


class ProtocolError(RuntimeError):
    pass


class DisplayChoiceError(ValueError):
    """The display asked for is not there (or not one): the message lists the displays."""


# ---------------------------------------------------------------- framing (shared with the client)

def encode_message(header: dict, payload_size: int = 0) -> bytes:
    """The header line of a message; `payload_size` raw bytes must follow it."""
    if payload_size:
        header = dict(header, nbytes=int(payload_size))
    return json.dumps(header, separators=(",", ":")).encode("utf-8") + b"\n"


def read_message(stream):
    """(header dict, payload bytearray) from a binary stream, or None at its end."""
    line = stream.readline(MAX_HEADER_BYTES + 1)
    if not line:
        return None
    if not line.endswith(b"\n"):
        raise ProtocolError("a message header is longer than 64 KiB or ends without a newline")
    try:
        header = json.loads(line)
    except ValueError as exc:
        raise ProtocolError(f"a message header is not JSON: {line[:200]!r}") from exc
    if not isinstance(header, dict):
        raise ProtocolError(f"a message header is not a JSON object: {line[:200]!r}")
    size = header.get("nbytes", 0)
    if not isinstance(size, int) or size < 0 or size > MAX_FRAME_PIXELS * 3:
        raise ProtocolError(f"a message's nbytes is not a size: {size!r}")
    payload = bytearray(size)
    view, done = memoryview(payload), 0
    while done < size:
        got = stream.readinto(view[done:])
        if not got:
            raise ProtocolError(f"the stream ended {size - done} bytes before the end of a message")
        done += got
    return header, payload


# ---------------------------------------------------------------- choosing a display (no SDL needed)

def display_listing(displays: list) -> str:
    return ", ".join(f"{d['index']} '{d['name']}' {d['width']}x{d['height']} at ({d['x']}, {d['y']})"
                     for d in displays) or "none"


def choose_display(displays: list, wanted) -> dict:
    """The display `wanted` names: an index (an int, or a string of digits), or a case-insensitive part
    of its name (a whole name that matches wins over parts of others)."""
    if isinstance(wanted, bool) or not isinstance(wanted, (int, str)):
        raise DisplayChoiceError(f"a display is chosen by its index or by a part of its name, not by "
                                 f"{wanted!r}; the displays: {display_listing(displays)}")
    if isinstance(wanted, str) and wanted.strip().isdigit():
        wanted = int(wanted.strip())
    if isinstance(wanted, int):
        for d in displays:
            if d["index"] == wanted:
                return d
        raise DisplayChoiceError(f"there is no display {wanted} ({len(displays)} connected); the displays: "
                                 f"{display_listing(displays)}")
    text = wanted.strip().casefold()
    if not text:
        raise DisplayChoiceError(f"the display's name is empty; the displays: {display_listing(displays)}")
    matches = ([d for d in displays if d["name"].casefold() == text]
               or [d for d in displays if text in d["name"].casefold()])
    if not matches:
        raise DisplayChoiceError(f"no display's name contains '{wanted}'; the displays: "
                                 f"{display_listing(displays)}")
    if len(matches) > 1:
        raise DisplayChoiceError(f"'{wanted}' is in the names of displays "
                                 f"{', '.join(str(d['index']) for d in matches)}: give the index or more of "
                                 f"the name; the displays: {display_listing(displays)}")
    return matches[0]


# ---------------------------------------------------------------- the SDL side

INVISIBLE_DRIVERS = ("offscreen", "dummy", "evdev")


def _prepare_environment(environ=os.environ) -> None:
    """Before SDL starts: XWayland rather than Wayland (see the module's docstring)."""
    if environ.get("WAYLAND_DISPLAY") and environ.get("DISPLAY") and not environ.get("SDL_VIDEODRIVER"):
        environ["SDL_VIDEODRIVER"] = "x11"


def _import_sdl2():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "Using SDL2 binaries from pysdl2-dll": not news
        import sdl2
    return sdl2


class Window:
    """SDL's video, one window at most, and the last frame (drawn again when the surface is remade)."""

    def __init__(self, sdl2):
        self.sdl2 = sdl2
        sdl2.SDL_SetHint(b"SDL_WINDOWS_DPI_AWARENESS", b"permonitorv2")
        sdl2.SDL_SetHint(b"SDL_VIDEO_MINIMIZE_ON_FOCUS_LOSS", b"0")
        sdl2.SDL_SetHint(b"SDL_VIDEO_MAC_FULLSCREEN_SPACES", b"0")
        sdl2.SDL_SetHint(b"SDL_VIDEO_X11_NET_WM_BYPASS_COMPOSITOR", b"1")
        # Ctrl-C in the add-on's terminal reaches this process too: the add-on, not SDL, closes the window
        sdl2.SDL_SetHint(b"SDL_NO_SIGNAL_HANDLERS", b"1")
        if sdl2.SDL_Init(sdl2.SDL_INIT_VIDEO) != 0:
            raise RuntimeError(f"SDL could not start its video: {self.error()}")
        self.driver = (sdl2.SDL_GetCurrentVideoDriver() or b"").decode("utf-8", "replace")
        # X11 and Windows have a software framebuffer of their own: SDL must not stand an OpenGL or
        # Direct3D texture in between (its default on X11)
        self.framebuffer = "texture"
        if self.driver in ("x11", "windows"):
            sdl2.SDL_SetHint(b"SDL_FRAMEBUFFER_ACCELERATION", b"0")
            self.framebuffer = "software"
        version = sdl2.SDL_version()
        sdl2.SDL_GetVersion(version)
        self.sdl_version = f"{version.major}.{version.minor}.{version.patch}"
        self.window = None
        self.display = None
        self.frames = 0
        self.last = None  # (width, height, bytes) of the frame on screen
        self.wake_type = sdl2.SDL_RegisterEvents(1)

    def error(self) -> str:
        return (self.sdl2.SDL_GetError() or b"").decode("utf-8", "replace") or "no reason given"

    def hello(self) -> dict:
        return {"event": "ready", "sdl": self.sdl_version, "pysdl2": getattr(self.sdl2, "__version__", "?"),
                "driver": self.driver, "framebuffer": self.framebuffer, "pid": os.getpid(),
                "python": sys.version.split()[0]}

    def refuse_invisible_driver(self) -> None:
        """SDL falls back to a driver that draws nowhere when there is no desktop: its 'display' is not a
        screen (a capture would "project" into nothing); only a driver asked for by name (tests) is allowed."""
        if self.driver in INVISIBLE_DRIVERS and not os.environ.get("SDL_VIDEODRIVER"):
            raise RuntimeError(f"there is no screen here (SDL found only its '{self.driver}' driver): run this on "
                               "the computer the projector is connected to, in its desktop session")

    def displays(self) -> list:
        self.refuse_invisible_driver()  # listed, it would be offered as a projector's display
        sdl2 = self.sdl2
        count = sdl2.SDL_GetNumVideoDisplays()
        if count < 0:
            raise RuntimeError(f"SDL cannot count the displays: {self.error()}")
        found = []
        for index in range(count):
            bounds = sdl2.SDL_Rect()
            if sdl2.SDL_GetDisplayBounds(index, bounds) != 0:
                raise RuntimeError(f"SDL cannot read display {index}'s bounds: {self.error()}")
            mode = sdl2.SDL_DisplayMode()
            has_mode = sdl2.SDL_GetCurrentDisplayMode(index, mode) == 0
            name = sdl2.SDL_GetDisplayName(index)
            found.append({"index": index, "name": name.decode("utf-8", "replace") if name else f"display {index}",
                          "x": bounds.x, "y": bounds.y, "width": bounds.w, "height": bounds.h,
                          "mode_width": mode.w if has_mode else None, "mode_height": mode.h if has_mode else None,
                          "refresh_hz": mode.refresh_rate if has_mode else None})
        return found

    def open(self, wanted) -> dict:
        sdl2 = self.sdl2
        self.refuse_invisible_driver()
        if self.window is not None:
            self.destroy()
        display = choose_display(self.displays(), wanted)
        title = f"LAPIG projector output (display {display['index']}: {display['name']})".encode("utf-8")
        # created at the display's bounds and size, then full screen: a window manager makes it full
        # screen on the display it is on, and without one it already covers the display
        flags = (sdl2.SDL_WINDOW_FULLSCREEN_DESKTOP | sdl2.SDL_WINDOW_BORDERLESS | sdl2.SDL_WINDOW_ALLOW_HIGHDPI
                 | sdl2.SDL_WINDOW_SHOWN)
        window = sdl2.SDL_CreateWindow(title, display["x"], display["y"], display["width"], display["height"],
                                       flags)
        if not window:
            raise RuntimeError(f"SDL could not create the window: {self.error()}")
        self.window, self.display, self.last = window, display, None
        sdl2.SDL_ShowCursor(sdl2.SDL_DISABLE)
        sdl2.SDL_RaiseWindow(window)
        on = sdl2.SDL_GetWindowDisplayIndex(window)
        if on != display["index"]:
            self.destroy()
            raise RuntimeError(f"the window went to display {on} instead of {display['index']}")
        surface = self.surface()
        sdl2.SDL_FillRect(surface, None, 0)
        if sdl2.SDL_UpdateWindowSurface(window) != 0:
            raise RuntimeError(f"SDL could not draw the window: {self.error()}")
        return {"ok": True, "display": display, "size": [surface.contents.w, surface.contents.h],
                "pixel_format": self.pixel_format(surface), "sdl": self.sdl_version, "driver": self.driver,
                "framebuffer": self.framebuffer, "title": title.decode("utf-8"), "x11_window": self.x11_window()}

    def x11_window(self):
        """The X11 window's id (for xdotool and xwininfo), None elsewhere."""
        sdl2 = self.sdl2
        info = sdl2.SDL_SysWMinfo()
        sdl2.SDL_VERSION(info.version)
        if not sdl2.SDL_GetWindowWMInfo(self.window, info) or info.subsystem != sdl2.SDL_SYSWM_X11:
            return None
        return int(info.info.x11.window)

    def surface(self):
        surface = self.sdl2.SDL_GetWindowSurface(self.window)
        if not surface:
            raise RuntimeError(f"SDL has no surface for the window: {self.error()}")
        return surface

    def pixel_format(self, surface) -> str:
        name = self.sdl2.SDL_GetPixelFormatName(surface.contents.format.contents.format)
        return name.decode("ascii", "replace") if name else "?"

    def show(self, width, height, pixels: bytearray) -> dict:
        self.load(width, height, pixels)
        return self.present()

    def present(self) -> dict:
        """The loaded frame on screen (SDL_UpdateWindowSurface); "t": time.monotonic() once it returned, the
        clock every process of this machine shares (the windows of several projectors compare theirs)."""
        import time

        if self.window is None:
            raise RuntimeError("no window is open: send 'open' first")
        if self.sdl2.SDL_UpdateWindowSurface(self.window) != 0:
            raise RuntimeError(f"SDL could not draw the window: {self.error()}")
        self.frames += 1
        return {"ok": True, "frame": self.frames, "t": time.monotonic()}

    def load(self, width, height, pixels: bytearray) -> dict:
        """The frame into the window's surface, not yet on screen (present() puts it there)."""
        import ctypes

        sdl2 = self.sdl2
        if self.window is None:
            raise RuntimeError("no window is open: send 'open' first")
        if not (isinstance(width, int) and isinstance(height, int) and width > 0 and height > 0):
            raise RuntimeError(f"a frame's width and height must be positive integers, not {width!r}x{height!r}")
        if len(pixels) != width * height * 3:
            raise RuntimeError(f"a {width}x{height} RGB frame is {width * height * 3} bytes, not {len(pixels)}")
        surface = self.surface()
        sw, sh = surface.contents.w, surface.contents.h
        if width > sw or height > sh:
            raise RuntimeError(f"the frame is {width}x{height} but display {self.display['index']} "
                               f"'{self.display['name']}' shows {sw}x{sh}: a frame is shown 1:1, never scaled")
        buffer = (ctypes.c_char * len(pixels)).from_buffer(pixels)
        source = sdl2.SDL_CreateRGBSurfaceWithFormatFrom(buffer, width, height, 24, width * 3,
                                                         sdl2.SDL_PIXELFORMAT_RGB24)
        if not source:
            raise RuntimeError(f"SDL could not wrap the frame: {self.error()}")
        try:
            if (width, height) != (sw, sh):
                sdl2.SDL_FillRect(surface, None, 0)
            sdl2.SDL_SetSurfaceBlendMode(source, sdl2.SDL_BLENDMODE_NONE)
            if sdl2.SDL_BlitSurface(source, None, surface, sdl2.SDL_Rect(0, 0, width, height)) != 0:
                raise RuntimeError(f"SDL could not copy the frame: {self.error()}")
        finally:
            sdl2.SDL_FreeSurface(source)
            del buffer
        self.last = (width, height, pixels)
        return {"ok": True}

    def redraw(self) -> None:
        """After the window was uncovered or its surface remade: the last frame again."""
        if self.window is None:
            return
        if self.last is not None:
            try:
                self.show(*self.last)
                self.frames -= 1  # not a new frame
                return
            except RuntimeError:
                pass
        self.sdl2.SDL_UpdateWindowSurface(self.window)

    def destroy(self) -> None:
        if self.window is not None:
            self.sdl2.SDL_DestroyWindow(self.window)
        self.window, self.display, self.last = None, None, None

    def quit(self) -> None:
        self.destroy()
        self.sdl2.SDL_Quit()


class Helper:
    def __init__(self, stdin, stdout):
        self.stdin, self.stdout = stdin, stdout
        self.requests: queue.Queue = queue.Queue()
        self.window = None
        self.write_lock = threading.Lock()

    def send(self, header: dict) -> None:
        with self.write_lock:
            self.stdout.write(encode_message(header))
            self.stdout.flush()

    def read_requests(self) -> None:
        """The reader thread: each message into the queue, then a wake-up event for SDL's loop."""
        try:
            while True:
                message = read_message(self.stdin)
                self.requests.put(message)
                self.wake()
                if message is None:
                    return
        except (ProtocolError, OSError, ValueError) as exc:
            self.requests.put(exc)
            self.wake()

    def wake(self) -> None:
        window = self.window
        if window is None:
            return
        sdl2 = window.sdl2
        event = sdl2.SDL_Event()
        event.type = window.wake_type
        sdl2.SDL_PushEvent(event)

    def handle(self, header: dict, payload: bytearray) -> bool:
        """Answer one request; False when the process should end."""
        cmd = header.get("cmd")
        try:
            if cmd == "displays":
                self.send({"ok": True, "displays": self.window.displays()})
            elif cmd == "open":
                self.send(self.window.open(header.get("display")))
            elif cmd == "show":
                self.send(self.window.show(header.get("width"), header.get("height"), payload))
            elif cmd == "load":
                self.send(self.window.load(header.get("width"), header.get("height"), payload))
            elif cmd == "present":
                self.send(self.window.present())
            elif cmd == "close":
                self.window.destroy()
                self.send({"ok": True})
                return False
            else:
                self.send({"ok": False,
                           "error": f"unknown request {cmd!r} (displays, open, show, load, present, close)"})
        except (RuntimeError, DisplayChoiceError) as exc:
            self.send({"ok": False, "error": str(exc)})
        return True

    def closed_by_user(self, event) -> bool:
        sdl2 = self.window.sdl2
        if event.type == sdl2.SDL_QUIT:
            return True
        if event.type == sdl2.SDL_WINDOWEVENT and event.window.event == sdl2.SDL_WINDOWEVENT_CLOSE:
            return True
        return event.type == sdl2.SDL_KEYDOWN and event.key.keysym.sym == sdl2.SDLK_ESCAPE

    def run(self) -> int:
        try:
            sdl2 = _import_sdl2()
        except ImportError as exc:
            self.send({"event": "error", "message": f"PySDL2 or its SDL2 library is missing ({exc}): install "
                                                    f"the pip packages pysdl2 and pysdl2-dll"})
            return 1
        try:
            self.window = Window(sdl2)
        except RuntimeError as exc:
            self.send({"event": "error", "message": str(exc)})
            return 1
        reader = threading.Thread(target=self.read_requests, name="lapig-window-stdin", daemon=True)
        reader.start()
        self.send(self.window.hello())
        event = sdl2.SDL_Event()
        try:
            while True:
                if sdl2.SDL_WaitEventTimeout(event, 200):
                    if self.closed_by_user(event):
                        self.window.destroy()
                        self.send({"event": "closed", "message": CLOSED_BY_USER})
                        return 0
                    if event.type == sdl2.SDL_WINDOWEVENT and event.window.event in (
                            sdl2.SDL_WINDOWEVENT_EXPOSED, sdl2.SDL_WINDOWEVENT_SIZE_CHANGED):
                        self.window.redraw()
                while True:  # every request waiting, whatever woke the loop
                    try:
                        message = self.requests.get_nowait()
                    except queue.Empty:
                        break
                    if message is None:  # stdin's end: the add-on is gone
                        return 0
                    if isinstance(message, Exception):
                        self.send({"event": "error", "message": f"the request stream broke: {message}"})
                        return 1
                    if not self.handle(*message):
                        return 0
        except Exception as exc:  # noqa: BLE001  (said on the pipe, then the process ends)
            self.send({"event": "error", "message": f"the projector window failed: {type(exc).__name__}: {exc}"})
            return 1
        finally:
            self.window.quit()


def main() -> int:
    import signal

    _prepare_environment()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # see SDL_NO_SIGNAL_HANDLERS: stdin's end or 'close' ends it
    # the protocol owns the real stdout; anything else printed (a library's note) goes to stderr
    protocol_out = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    sys.stdout = sys.stderr
    try:
        return Helper(sys.stdin.buffer, protocol_out).run()
    except BrokenPipeError:  # the add-on went away mid-answer
        return 0


if __name__ == "__main__":
    sys.exit(main())
