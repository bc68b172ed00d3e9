# SPDX-License-Identifier: GPL-3.0-or-later
"""A local model hub (HTTP on 127.0.0.1) that answers as the Hugging Face Hub does, for the model manager's tests and
`bench diffusion`: the tree listing with sizes and hashes (paged), resolve/<revision>/<file> as a redirect to a
"CDN" path that honours Range, a token check, and faults on request.

Faults: token='...' (files and listing need Authorization: Bearer that token; another one is refused with 401),
kill_once={path} (the first read of that file sends half its bytes and drops the connection), corrupt={path}
(its bytes are changed, the listing keeps the true hash), slow_s (a pause per 64 kB block: a cancel mid-file),
gated=True (403 GatedRepo without a token). `requests` records (path, Range header, Authorization header)."""
from __future__ import annotations

import hashlib
import http.server
import json
import os
import threading
import time
import urllib.parse

BLOCK = 64 * 1024
LFS_SUFFIXES = (".safetensors", ".bin", ".ckpt")


def _entry(folder: str, rel: str) -> dict:
    with open(os.path.join(folder, rel), "rb") as f:
        data = f.read()
    entry = {"type": "file", "path": rel, "size": len(data),
             "oid": hashlib.sha1(f"blob {len(data)}\0".encode() + data).hexdigest()}
    if rel.endswith(LFS_SUFFIXES):
        entry["lfs"] = {"oid": hashlib.sha256(data).hexdigest(), "size": len(data), "pointerSize": 134}
    return entry


class FakeModelHub:
    """`with FakeModelHub({'tiny/ip2p': folder}) as hub:` the endpoint is hub.url."""

    def __init__(self, repos: dict, token: str = "", page_size: int = 7, gated: bool = False):
        self.repos = {repo: os.path.abspath(str(folder)) for repo, folder in repos.items()}
        self.token, self.page_size, self.gated = token, page_size, gated
        self.kill_once: set = set()
        self.corrupt: set = set()
        self.slow_s = 0.0
        self.requests: list = []
        self._killed: set = set()
        self._server = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self._server.server_address[1]}"

    def listing(self, repo: str) -> list[dict]:
        folder = self.repos[repo]
        rels = sorted(os.path.relpath(os.path.join(r, n), folder).replace(os.sep, "/")
                      for r, _, names in os.walk(folder) for n in names)
        return [_entry(folder, rel) for rel in rels]

    def file_requests(self, path: str) -> list:
        return [r for r in self.requests if r[0].endswith("/" + path) and "/cdn/" in r[0]]

    def __enter__(self):
        hub = self

        class Handler(http.server.BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args):
                pass

            def _fail(self, code: int, error_code: str = "", message: str = ""):
                body = json.dumps({"error": message or error_code}).encode()
                self.send_response(code)
                if error_code:
                    self.send_header("X-Error-Code", error_code)
                if message:
                    self.send_header("X-Error-Message", message)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def _refused(self) -> bool:
                auth = self.headers.get("Authorization", "")
                if hub.token and auth and auth != f"Bearer {hub.token}":
                    self._fail(401, message="Invalid credentials in Authorization header")
                    return True
                if (hub.token or hub.gated) and not auth:
                    self._fail(403 if hub.gated else 401, "GatedRepo" if hub.gated else "",
                               "Access to model is restricted")
                    return True
                return False

            def _repo_of(self, parts):
                for n in (2, 1):
                    repo = "/".join(parts[:n])
                    if repo in hub.repos:
                        return repo, parts[n:]
                return None, parts

            def do_GET(self):
                url = urllib.parse.urlsplit(self.path)
                path = urllib.parse.unquote(url.path)
                hub.requests.append((path, self.headers.get("Range", ""), self.headers.get("Authorization", "")))
                parts = path.strip("/").split("/")
                if parts[:2] == ["api", "models"]:
                    repo, rest = self._repo_of(parts[2:])
                    if repo is None or rest[:1] != ["tree"]:
                        return self._fail(404, "RepoNotFound", "Repository not found")
                    if self._refused():
                        return None
                    return self._tree(repo, urllib.parse.parse_qs(url.query))
                if parts[:1] == ["cdn"]:
                    repo, rest = self._repo_of(parts[1:])
                    return self._file(repo, "/".join(rest))
                repo, rest = self._repo_of(parts)
                if repo is None:
                    return self._fail(404, "RepoNotFound", "Repository not found")
                if rest[:1] != ["resolve"] or len(rest) < 3:
                    return self._fail(404, "EntryNotFound")
                if self._refused():
                    return None
                rel = "/".join(rest[2:])
                if not os.path.isfile(os.path.join(hub.repos[repo], rel)):
                    return self._fail(404, "EntryNotFound", "Entry not found")
                self.send_response(302)  # as the Hub sends its large files to a CDN
                self.send_header("Location", f"/cdn/{repo}/{urllib.parse.quote(rel)}")
                self.send_header("Content-Length", "0")
                self.end_headers()
                return None

            def _tree(self, repo, query):
                entries = hub.listing(repo)
                start = int(query.get("cursor", ["0"])[0])
                page = entries[start:start + hub.page_size]
                body = json.dumps(page).encode()
                self.send_response(200)
                if start + hub.page_size < len(entries):
                    self.send_header("Link", f'<{self.path.split("?")[0]}?recursive=true&cursor='
                                             f'{start + hub.page_size}>; rel="next"')
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def _file(self, repo, rel):
                full = os.path.join(hub.repos.get(repo, "/nonexistent"), rel)
                if repo is None or not os.path.isfile(full):
                    return self._fail(404, "EntryNotFound")
                with open(full, "rb") as f:
                    data = f.read()
                if rel in hub.corrupt:
                    data = bytes([data[0] ^ 0xFF]) + data[1:]
                start = 0
                rng = self.headers.get("Range", "")
                if rng.startswith("bytes="):
                    start = int(rng[6:].split("-")[0] or 0)
                    if start >= len(data):
                        return self._fail(416)
                    self.send_response(206)
                    self.send_header("Content-Range", f"bytes {start}-{len(data) - 1}/{len(data)}")
                else:
                    self.send_response(200)
                body = data[start:]
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Accept-Ranges", "bytes")
                self.end_headers()
                kill = rel in hub.kill_once and rel not in hub._killed
                if kill:
                    hub._killed.add(rel)
                    self.wfile.write(body[:len(body) // 2])
                    self.wfile.flush()
                    self.close_connection = True
                    return None
                try:
                    for i in range(0, len(body), BLOCK):
                        self.wfile.write(body[i:i + BLOCK])
                        if hub.slow_s:
                            self.wfile.flush()
                            time.sleep(hub.slow_s)
                except (BrokenPipeError, ConnectionResetError):  # the client stopped (a cancel)
                    self.close_connection = True
                return None

        self._server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._server.daemon_threads = True
        threading.Thread(target=self._server.serve_forever, name="fake model hub", daemon=True).start()
        return self

    def __exit__(self, *exc):
        self._server.shutdown()
        self._server.server_close()
