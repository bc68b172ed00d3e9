# SPDX-License-Identifier: GPL-3.0-or-later
"""The projector output: a borderless full-screen window on a chosen display, shown 1:1.

`ProjectorWindow` (the ProjectorOutput of lapig_core.rig) runs `window_process` (SDL2 through PySDL2) as
a child process of the same Python (in Blender: Blender's own, sys.executable) and talks to it over
pipes, so Blender never has to place a window itself. Every call waits for the helper's answer with a
timeout and raises RigError with what the helper said and the end of its stderr; the helper is killed on
close() and on any failure. The user may close the window (Esc or its close button): the next call
raises RigError saying so. Calls may come from any thread (one at a time; a lock keeps them in order).
"""
from __future__ import annotations

import collections
import importlib.util
import os
import queue
import subprocess
import sys
import threading
import time
import weakref

import numpy as np

from ..common.closing import Closing
from . import RigError
from .window_process import CLOSED_BY_USER, ProtocolError, encode_message, read_message

HELPER_MODULE = "lapig_core.rig.window_process"
START_TIMEOUT_S = 20.0  # Python, SDL and the window manager's first answer
CALL_TIMEOUT_S = 10.0
CLOSED_MESSAGE = "the projector window was closed (Esc or the window's close button)"
_EXTENSION_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _package_dir(name: str) -> str | None:
    """The folder holding the top-level package `name` here (not imported), for the helper's path."""
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return None
    if spec is None:
        return None
    origin = spec.origin
    if origin in (None, "namespace"):
        origin = next(iter(spec.submodule_search_locations or []), None)
    if not origin:
        return None
    package = os.path.dirname(origin) if os.path.basename(origin).startswith("__init__") else origin
    return os.path.dirname(package)


def helper_environment(base: dict | None = None) -> dict:
    """The helper's environment: PYTHONPATH leads with the extension's root (lapig_core without the
    extension's package around it) and the folders of sdl2 and sdl2dll as this Python finds them (in
    Blender: the extension's wheels' site-packages, which a child Python would not see)."""
    env = dict(os.environ if base is None else base)
    paths = [_EXTENSION_ROOT]
    for name in ("sdl2", "sdl2dll"):
        folder = _package_dir(name)
        if folder and folder not in paths:
            paths.append(folder)
    if env.get("PYTHONPATH"):
        paths.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(paths)
    env["PYTHONIOENCODING"] = "utf-8"
    return env


class _Helper:
    """The child process, its two pipe readers, its one writer and the answers waiting to be taken."""

    def __init__(self, python: str, env: dict | None):
        self.messages: queue.Queue = queue.Queue()
        self.stderr_tail: collections.deque = collections.deque(maxlen=60)
        self.closed_by_user = False
        self.fatal: str | None = None
        self.exited = threading.Event()
        kwargs = {}
        if os.name == "nt":
            kwargs["creationflags"] = getattr(subprocess, "CREATE_NO_WINDOW", 0)
        try:
            self.proc = subprocess.Popen([python, "-m", HELPER_MODULE], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                         env=helper_environment(env), cwd=_EXTENSION_ROOT, **kwargs)
        except OSError as exc:
            raise RigError(f"the projector window's helper could not start with {python}: {exc}") from exc
        weakref.finalize(self, _kill, self.proc)  # at the interpreter's exit at the latest
        self._outbox: queue.Queue = queue.Queue()  # (bytes to write, done event) for the writer; None ends it
        threading.Thread(target=self._read_stdout, name="lapig-window-answers", daemon=True).start()
        threading.Thread(target=self._read_stderr, name="lapig-window-stderr", daemon=True).start()
        self._writer = threading.Thread(target=self._write_stdin, name="lapig-window-requests", daemon=True)
        self._writer.start()

    def _read_stdout(self) -> None:
        try:
            while True:
                message = read_message(self.proc.stdout)
                if message is None:
                    break
                header = message[0]
                header["_received"] = time.perf_counter()
                if header.get("event") == "closed":
                    self.closed_by_user = True
                elif header.get("event") == "error":
                    self.fatal = str(header.get("message"))
                self.messages.put(header)
        except (ProtocolError, OSError, ValueError) as exc:
            self.fatal = f"its answers broke off: {exc}"
        finally:
            self.exited.set()
            self.messages.put(None)
            self._outbox.put(None)  # the helper has ended: so does its writer

    def _write_stdin(self) -> None:
        """The writer: each request's bytes into the helper's stdin, in order; a write error is handed back."""
        while True:
            request = self._outbox.get()
            if request is None:
                return
            parts, done = request
            try:
                for part in parts:
                    self.proc.stdin.write(part)
                self.proc.stdin.flush()
            except (OSError, ValueError) as exc:
                done.error = exc
            done.set()

    def _read_stderr(self) -> None:
        try:
            for line in iter(self.proc.stderr.readline, b""):
                text = line.decode("utf-8", "replace").rstrip()
                if text:
                    self.stderr_tail.append(text)
        except (OSError, ValueError):
            pass

    def stderr_text(self, limit: int = 1500) -> str:
        text = " | ".join(self.stderr_tail)
        return text[-limit:]

    def alive(self) -> bool:
        return self.proc.poll() is None and not self.exited.is_set()

    def kill(self) -> None:
        _kill(self.proc)

    def send(self, header: dict, payload=None, timeout_s: float = CALL_TIMEOUT_S) -> None:
        """Write one request through the writer thread; OSError when it could not be written."""
        size = 0 if payload is None else memoryview(payload).nbytes
        done = _Written()
        self._outbox.put(([encode_message(header, size)] + ([payload] if size else []), done))
        deadline = time.monotonic() + timeout_s
        while not done.wait(0.05):
            if not self._writer.is_alive():  # the helper ended before the request was taken
                raise BrokenPipeError("the helper has ended")
            if time.monotonic() > deadline:
                # a helper that stops reading blocks the write for ever: killing it breaks the pipe, the write ends
                self.kill()
                done.wait(5.0)
                raise done.error or BrokenPipeError(f"the helper took no request for {timeout_s:.0f} s")
        if done.error is not None:
            raise done.error

    def receive(self, timeout_s: float) -> dict | None:
        """The next message, None when the helper ended; raises queue.Empty after timeout_s."""
        return self.messages.get(timeout=timeout_s)


class _Written(threading.Event):
    """Set by the writer thread once a request is written; `error`: why it could not be."""
    error: BaseException | None = None


def _kill(proc) -> None:
    if proc.poll() is None:
        try:
            proc.kill()
        except OSError:
            pass
    for stream in (proc.stdin, proc.stdout, proc.stderr):
        try:
            if stream is not None:
                stream.close()
        except (OSError, ValueError):
            pass
    try:
        proc.wait(timeout=5)
    except (subprocess.TimeoutExpired, OSError):
        pass


def _start(python: str, env: dict | None, timeout_s: float) -> tuple[_Helper, dict]:
    helper = _Helper(python, env)
    try:
        hello = helper.receive(timeout_s)
    except queue.Empty:
        helper.kill()
        raise RigError(f"the helper did not start within {timeout_s:.0f} s; its stderr: "
                       f"{helper.stderr_text() or 'nothing'}") from None
    if hello is None or hello.get("event") != "ready":
        helper.kill()
        said = (hello or {}).get("message") or helper.fatal or "it ended without a word"
        raise RigError(f"{said}; its stderr: {helper.stderr_text() or 'nothing'}")
    return helper, hello


def list_displays(python: str | None = None, timeout_s: float = START_TIMEOUT_S, env: dict | None = None) -> list:
    """The displays SDL sees: [{index, name, x, y, width, height, mode_width, mode_height, refresh_hz}]."""
    try:
        helper, _hello = _start(python or sys.executable, env, timeout_s)
    except RigError as exc:
        raise RigError(f"the displays could not be listed: {exc}") from None
    try:
        helper.send({"cmd": "displays"}, timeout_s=timeout_s)
        answer = helper.receive(timeout_s)
        if not answer or not answer.get("ok"):
            raise RigError(f"the displays could not be listed: {(answer or {}).get('error') or helper.fatal}; "
                           f"its stderr: {helper.stderr_text() or 'nothing'}")
        return answer["displays"]
    except (OSError, queue.Empty) as exc:
        raise RigError(f"the displays could not be listed: the helper did not answer ({exc!r}); its stderr: "
                       f"{helper.stderr_text() or 'nothing'}") from None
    finally:
        try:
            helper.send({"cmd": "close"}, timeout_s=2.0)
            helper.proc.wait(timeout=2.0)
        except (OSError, subprocess.TimeoutExpired, ValueError):
            pass
        helper.kill()


class ProjectorWindow(Closing):
    """The projector output on `display` (an index, or a case-insensitive part of its name as
    list_displays() gives it): opened on construction, the display's pixels shown 1:1."""

    def __init__(self, display, python: str | None = None, *, timeout_s: float = CALL_TIMEOUT_S,
                 start_timeout_s: float = START_TIMEOUT_S, env: dict | None = None):
        self.requested = display
        self.python = python or sys.executable
        self.timeout_s = float(timeout_s)
        self._lock = threading.RLock()
        self._helper: _Helper | None = None
        self._frames = 0
        try:
            self._helper, self._hello = _start(self.python, env, start_timeout_s)
            # a window dropped without close() still ends its helper
            weakref.finalize(self, _kill, self._helper.proc)
            answer = self._call({"cmd": "open", "display": display}, timeout_s=start_timeout_s)
        except RigError as exc:
            self.close()
            raise RigError(f"the projector window did not open on display '{display}': {exc}") from None
        self._opened = answer
        self._size = (int(answer["size"][0]), int(answer["size"][1]))

    # ---- the ProjectorOutput interface

    @property
    def size(self) -> tuple[int, int]:
        return self._size

    def show(self, frame) -> float:
        """Show an RGB uint8 (H, W, 3) frame 1:1 at the top-left (black around a smaller one); returns
        time.perf_counter() when the helper said the window was updated."""
        frame = self._checked(frame)
        height, width = frame.shape[:2]
        answer = self._call({"cmd": "show", "width": int(width), "height": int(height)}, payload=frame.reshape(-1))
        self._frames = int(answer.get("frame", self._frames + 1))
        return answer["_received"]

    def load(self, frame) -> None:
        """The frame into the window, not yet on screen: present() shows it (several windows of one rig load
        their frames, then present together: lapig_core.rig.frame_lock)."""
        frame = self._checked(frame)
        height, width = frame.shape[:2]
        self._call({"cmd": "load", "width": int(width), "height": int(height)}, payload=frame.reshape(-1))

    def present(self) -> float:
        """The loaded frame on screen; time.monotonic() in the helper once the window was updated (every
        process of the machine shares that clock: the skew between windows is measured with it)."""
        answer = self._call({"cmd": "present"})
        self._frames = int(answer.get("frame", self._frames + 1))
        return float(answer["t"])

    def _checked(self, frame) -> np.ndarray:
        frame = np.asarray(frame)
        if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
            raise RigError(f"a projector frame is uint8 RGB (H, W, 3), not {frame.dtype} {frame.shape}")
        height, width = frame.shape[:2]
        if width > self._size[0] or height > self._size[1]:
            raise RigError(f"the frame is {width}x{height} but the projector's display "
                           f"'{self._opened['display']['name']}' is {self._size[0]}x{self._size[1]}: frames are "
                           f"shown 1:1, never scaled; render at the projector's resolution")
        return np.ascontiguousarray(frame)

    def describe(self) -> dict:
        d = self._opened["display"]
        return {"kind": "projector window (SDL2)", "display": {k: d[k] for k in ("index", "name", "x", "y", "width",
                                                                                  "height", "refresh_hz") if k in d},
                "requested": self.requested, "size": list(self._size), "sdl_version": self._hello.get("sdl"),
                "pysdl2": self._hello.get("pysdl2"), "video_driver": self._hello.get("driver"),
                "framebuffer": self._hello.get("framebuffer"), "pixel_format": self._opened.get("pixel_format"),
                "frames_shown": self._frames, "helper_pid": self._hello.get("pid"),
                "x11_window": self._opened.get("x11_window")}

    def close(self) -> None:
        """Close the window and end the helper. From another thread while a call waits: the helper is
        killed, and that call raises RigError."""
        got = self._lock.acquire(timeout=1.0)
        try:
            helper, self._helper = self._helper, None
            if helper is None:
                return
            if got and helper.alive():
                try:
                    helper.send({"cmd": "close"}, timeout_s=2.0)
                    helper.proc.wait(timeout=2.0)
                except (OSError, ValueError, subprocess.TimeoutExpired):
                    pass
            helper.kill()
        finally:
            if got:
                self._lock.release()

    # ---- more

    @property
    def is_open(self) -> bool:
        helper = self._helper
        return helper is not None and helper.alive() and not helper.closed_by_user

    def _call(self, header: dict, payload=None, timeout_s: float | None = None) -> dict:
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        with self._lock:
            helper = self._helper
            if helper is None:
                raise RigError("the projector window is closed")
            self._raise_if_gone(helper)
            try:
                helper.send(header, payload, timeout_s)
            except (OSError, ValueError):
                self._fail(helper, "it stopped reading")
            deadline = time.monotonic() + timeout_s
            while True:
                try:
                    answer = helper.receive(max(0.0, deadline - time.monotonic()))
                except queue.Empty:
                    self._fail(helper, f"it did not answer '{header['cmd']}' within {timeout_s:.0f} s")
                if answer is None or answer.get("event") in ("closed", "error"):
                    self._raise_if_gone(helper, answer)
                    self._fail(helper, "it ended")
                if "ok" not in answer:
                    continue  # an event this side does not use
                if not answer["ok"]:
                    raise RigError(str(answer.get("error")))
                return answer

    def _raise_if_gone(self, helper: _Helper, answer: dict | None = None) -> None:
        if helper.closed_by_user or (answer or {}).get("event") == "closed":
            self._helper = None
            helper.kill()
            raise RigError(CLOSED_MESSAGE)
        if helper.fatal or (answer or {}).get("event") == "error":
            self._fail(helper, (answer or {}).get("message") or helper.fatal)

    def _fail(self, helper: _Helper, why: str):
        self._helper = None
        helper.exited.wait(1.0)  # a helper that is ending: its last words ('closed by user') first
        helper.kill()
        if helper.closed_by_user:
            raise RigError(CLOSED_MESSAGE)
        raise RigError(f"the projector window's helper failed: {why}; its stderr: "
                       f"{helper.stderr_text() or 'nothing'}")


__all__ = ["ProjectorWindow", "list_displays", "CLOSED_BY_USER", "CLOSED_MESSAGE", "helper_environment"]
