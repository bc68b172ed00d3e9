"""Virtual screens for the projector window's tests and ``bench hardware``: an X server with two monitors
side by side on one screen, as a desktop with a projector plugged in looks, and screenshots of it.

The server is Xvnc (TigerVNC): an Xvfb whose RandR outputs follow the screen layout a VNC client asks
for (asked here over the VNC protocol on a Unix socket). SDL2 sees displays as RandR outputs, and plain
Xvfb has one per X screen, on which SDL2 puts a full-screen window on screen 0 whatever display it was
given. Install: apt-get install -y --no-install-recommends tigervnc-standalone-server x11-apps xdotool.
"""
from __future__ import annotations

import contextlib
import importlib.util
import os
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np

MONITORS = [(0, 0, 640, 480), (640, 0, 800, 600)]  # x, y, width, height
ROOT_SIZE = (1440, 600)
APT = "apt-get install -y --no-install-recommends tigervnc-standalone-server x11-apps xdotool"


def missing_tools() -> list[str]:
    tools = [tool for tool in ("Xvnc", "xwd", "xdotool") if shutil.which(tool) is None]
    missing = [f"{', '.join(tools)} ({APT})"] if tools else []
    if importlib.util.find_spec("sdl2") is None:
        missing.append("PySDL2 (pip install pysdl2 pysdl2-dll)")
    if not sys.platform.startswith("linux"):
        missing.append("Linux (the virtual X server)")
    return missing



def rfb_set_layout(path: str, monitors, root_size, timeout_s: float = 10.0) -> None:
    """As a VNC client: ask Xvnc for one screen per monitor (RFB 3.8, no security, SetDesktopSize)."""
    sock = socket.socket(socket.AF_UNIX)
    sock.settimeout(timeout_s)
    sock.connect(path)

    def take(n):
        data = b""
        while len(data) < n:
            chunk = sock.recv(n - len(data))
            if not chunk:
                raise OSError("Xvnc closed the VNC connection")
            data += chunk
        return data

    try:
        take(12)
        sock.sendall(b"RFB 003.008\n")
        types = take(take(1)[0])
        assert 1 in types, f"Xvnc offers no 'None' security: {list(types)}"
        sock.sendall(b"\x01")
        assert struct.unpack(">I", take(4)) == (0,)
        sock.sendall(b"\x01")  # ClientInit: shared
        take(4 + 16)
        take(struct.unpack(">I", take(4))[0])  # the desktop's name
        sock.sendall(struct.pack(">BBHi", 2, 0, 1, -308))  # SetEncodings: ExtendedDesktopSize
        message = struct.pack(">BBHHBB", 251, 0, root_size[0], root_size[1], len(monitors), 0)
        for i, (x, y, w, h) in enumerate(monitors):
            message += struct.pack(">IHHHHI", i + 1, x, y, w, h, 0)
        sock.sendall(message)
        sock.sendall(struct.pack(">BBHHHH", 3, 0, 0, 0, root_size[0], root_size[1]))  # update request
        take(4)  # FramebufferUpdate, its rectangle count
        _x, status, _w, _h, encoding = struct.unpack(">HHHHi", take(12))
        assert encoding == -308 and status == 0, f"Xvnc refused the layout (status {status})"
    finally:
        sock.close()



@contextlib.contextmanager
def two_monitors(monitors=MONITORS, root_size=ROOT_SIZE):
    """The environment (DISPLAY) of an Xvnc with ``monitors`` side by side on one screen, black root.
    RuntimeError when it cannot start (missing_tools() says why beforehand)."""
    problems = missing_tools()
    if problems:
        raise RuntimeError("needs " + "; ".join(problems))
    with tempfile.TemporaryDirectory(prefix="lapig-xvnc-") as folder:
        rfb, log = os.path.join(folder, "rfb"), os.path.join(folder, "xvnc.log")
        read_fd, write_fd = os.pipe()
        with open(log, "wb") as log_file:
            proc = subprocess.Popen(["Xvnc", "-displayfd", str(write_fd), "-geometry", "%dx%d" % tuple(root_size),
                                     "-depth", "24", "-SecurityTypes", "None", "-rfbport", "-1", "-rfbunixpath",
                                     rfb, "-nolisten", "tcp", "-br", "-ac"],
                                    pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=log_file)
        os.close(write_fd)
        try:
            with os.fdopen(read_fd, "rb") as f:
                number = f.readline().strip().decode()
            if not number:
                raise RuntimeError(f"Xvnc did not start: {open(log).read()[-1500:]}")
            for _ in range(100):
                if os.path.exists(rfb):
                    break
                time.sleep(0.05)
            rfb_set_layout(rfb, monitors, root_size)
            env = {k: v for k, v in os.environ.items() if k not in ("WAYLAND_DISPLAY", "SDL_VIDEODRIVER")}
            env["DISPLAY"] = f":{number}"
            yield env
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def read_xwd(data: bytes) -> np.ndarray:
    """An xwd ZPixmap dump of a TrueColor window as uint8 (H, W, 3) RGB."""
    header = [int(v) for v in np.frombuffer(data[:100], ">u4")]
    header_size, pixmap_format, width, height = header[0], header[2], header[4], header[5]
    byte_order, bits_per_pixel, bytes_per_line = header[7], header[11], header[12]
    masks, colours = header[14:17], header[19]
    assert pixmap_format == 2, "not a ZPixmap"
    start = header_size + colours * 12
    rows = np.frombuffer(data, np.uint8, offset=start, count=bytes_per_line * height).reshape(height, bytes_per_line)
    step = bits_per_pixel // 8
    cells = rows[:, :width * step].reshape(height, width, step).astype(np.uint32)
    order = range(step) if byte_order == 0 else range(step - 1, -1, -1)  # 0: least significant byte first
    value = sum(cells[..., i] << (8 * k) for k, i in enumerate(order))
    channels = [((value & m) >> ((m & -m).bit_length() - 1)).astype(np.uint8) for m in masks]
    return np.stack(channels, axis=-1)



def screenshot(env, root_size=ROOT_SIZE) -> np.ndarray:
    """The root window as uint8 (H, W, 3) RGB."""
    run = subprocess.run(["xwd", "-root", "-silent"], env=env, capture_output=True, timeout=30)
    if run.returncode != 0:
        raise RuntimeError(run.stderr.decode())
    image = read_xwd(run.stdout)
    assert image.shape == (root_size[1], root_size[0], 3)
    return image


def region(image, monitor, monitors=MONITORS):
    x, y, w, h = monitors[monitor]
    return image[y:y + h, x:x + w]
