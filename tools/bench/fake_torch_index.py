"""A local package index (PEP 503, over HTTP on 127.0.0.1) holding a tiny fake torch wheel, for bench ui's
install_to_import_seconds and the tests of the preferences' Install torch: pip installs it as it would PyTorch's.

The wheel's torch has version.py as torch's own (installed_torch reads it) and imports in a millisecond.
hold=True keeps the wheel's download waiting until release() (a cancel mid-download); send_seconds spreads its
bytes over that time (pip's progress lines)."""
from __future__ import annotations

import base64
import hashlib
import http.server
import os
import threading
import time
import zipfile

FAKE_VERSION = "2.13.0"


def _record_line(name: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def make_fake_torch_wheel(folder, version: str = FAKE_VERSION, padding_bytes: int = 0) -> str:
    """torch-VERSION-py3-none-any.whl in folder: a package `torch` whose __version__ is VERSION. padding_bytes:
    a data file of that size (pip shows its download progress only for files over 512 kB)."""
    os.makedirs(folder, exist_ok=True)
    info = f"torch-{version}.dist-info"
    files = {
        "torch/__init__.py": b"from . import backends, version\n__version__ = version.__version__\n",
        "torch/version.py": f"__version__ = '{version}'\ncuda = None\n".encode(),
        "torch/backends/__init__.py": b"",
        f"{info}/METADATA": f"Metadata-Version: 2.1\nName: torch\nVersion: {version}\n".encode(),
        f"{info}/WHEEL": b"Wheel-Version: 1.0\nGenerator: lapig-tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n",
        f"{info}/top_level.txt": b"torch\n",
    }
    if padding_bytes:
        files["torch/_padding.bin"] = os.urandom(padding_bytes)  # random: the zip cannot shrink it
    record = [_record_line(name, data) for name, data in files.items()] + [f"{info}/RECORD,,"]
    path = os.path.join(str(folder), f"torch-{version}-py3-none-any.whl")
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as whl:
        for name, data in files.items():
            whl.writestr(name, data)
        whl.writestr(f"{info}/RECORD", "\n".join(record) + "\n")
    return path


class LocalIndex:
    """`with LocalIndex(wheel) as index:` pip's --index-url is index.url."""

    def __init__(self, wheel: str, hold: bool = False, send_seconds: float = 0.0):
        self.wheel, self.send_seconds = wheel, send_seconds  # send_seconds: the wheel's bytes come over that time
        self.name = os.path.basename(wheel)
        with open(wheel, "rb") as f:
            self.data = f.read()
        self.sha256 = hashlib.sha256(self.data).hexdigest()
        self.wheel_requested = threading.Event()
        self._released = threading.Event()
        if not hold:
            self._released.set()
        self._server = None

    def release(self):
        self._released.set()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self._server.server_address[1]}/simple/"

    def __enter__(self):
        index = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args):  # quiet
                pass

            def _send(self, body: bytes, kind: str, seconds: float = 0.0):
                self.send_response(200)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                parts = 10 if seconds > 0 else 1  # a slow line: pip's progress moves in steps
                for i in range(parts):
                    self.wfile.write(body[i * len(body) // parts:(i + 1) * len(body) // parts])
                    self.wfile.flush()
                    time.sleep(seconds / parts)

            def do_GET(self):
                path = self.path.split("?")[0]
                if path in ("/simple/", "/simple"):
                    return self._send(b'<html><body><a href="torch/">torch</a></body></html>', "text/html")
                if path in ("/simple/torch/", "/simple/torch"):
                    link = f'<a href="/files/{index.name}#sha256={index.sha256}">{index.name}</a>'
                    return self._send(f"<html><body>{link}</body></html>".encode(), "text/html")
                if path == f"/files/{index.name}":
                    index.wheel_requested.set()
                    index._released.wait(120)  # hold: pip waits here, as on a slow line
                    try:
                        return self._send(index.data, "application/octet-stream", index.send_seconds)
                    except (BrokenPipeError, ConnectionResetError):  # pip was stopped meanwhile
                        return None
                self.send_error(404)

        self._server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._server.daemon_threads = True
        threading.Thread(target=self._server.serve_forever, name="fake torch index", daemon=True).start()
        return self

    def __exit__(self, *exc):
        self._released.set()
        self._server.shutdown()
        self._server.server_close()


def isolated_pip_env(cache_dir) -> dict:
    """This process's environment without the machine's pip settings (find-links, extra indexes, constraints):
    pip sees the local index only, and caches under cache_dir."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PIP_")}
    env.update(PIP_CONFIG_FILE=os.devnull, PIP_CACHE_DIR=str(cache_dir), PIP_DISABLE_PIP_VERSION_CHECK="1")
    env.pop("LAPIG_TORCH_INDEX_URL", None)
    return env
