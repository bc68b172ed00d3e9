# SPDX-License-Identifier: GPL-3.0-or-later
"""Download a catalogue model into the models folder: listed, resumable, checked, renamed into place.

1. The repository's listing (hub.list_files) gives each file's size and hash; model_index.json says which
   components the pipeline has, and only their files are fetched (no root checkpoints, no other formats of the
   same weights: see select_files).
2. Each file goes to PARTIAL/<path>.part, from where a stopped download left it (HTTP Range); a connection that
   breaks mid-file is resumed at once (RETRIES times), a cancel or a failure leaves the .part for the next try.
3. A file is renamed from .part only when its size and hash match the listing (sha256 for the LFS files, git's
   blob sha1 for the others); a file that does not match is deleted and named in the error.
4. When every file is there and the folder is a whole pipeline (for one model, an adapter: config.json and its
   weights, select_model_files), MANIFEST is written and PARTIAL renamed to the
   model's folder. Until then nothing is at that name: a failed or cancelled download never looks ready.
Nothing is fetched unless the caller says Blender allows online access.
"""
from __future__ import annotations

import errno
import http.client
import json
import os
import shutil
import socket
import threading
import time
from dataclasses import dataclass, replace
from typing import Callable

from ..common.locking import FolderLock
from . import pipeline_folder as pf
from .catalogue import MODEL, CatalogueModel, ModelError
from .hub import Hub, RemoteFile

CHUNK = 1 << 20
RETRIES = 3
REPORT_S = 0.1  # at most this often a progress line
SKIP_SUFFIXES = (".ckpt", ".msgpack", ".h5", ".onnx", ".onnx_data", ".pb", ".tflite", ".ot", ".mlmodel", ".gguf")
ONLINE_OFF = ("Online access is off in Blender: allow it in Preferences > System > Network (Allow Online Access), "
              "or use a folder you already have (Use Folder)")
OFFLINE_MODE = ("Blender was started offline (--offline-mode): start it without that option to download models, "
                "or use a folder you already have (Use Folder)")


class DownloadCancelled(Exception):
    """The user cancelled: the .part files stay for the next Download."""


def online_refusal(online_access: bool, overridden: bool = False) -> str:
    if online_access:
        return ""
    return OFFLINE_MODE if overridden else ONLINE_OFF


def partial_folder(root: str, key: str) -> str:
    return os.path.join(root, pf.PARTIAL_PREFIX + key)


def model_folder(root: str, key: str) -> str:
    return os.path.join(root, key)


def _variant(name: str) -> bool:
    """diffusion_pytorch_model.fp16.safetensors, model.non_ema.bin: a variant of the component's weights."""
    return name.endswith(pf.WEIGHT_SUFFIXES) and name.count(".") >= 2


def _half_copies(parts: list[RemoteFile]) -> dict[str, RemoteFile]:
    """A component's fp16 weights by the default file they stand for ('unet/x.safetensors' -> its x.fp16 copy),
    only where every default safetensors file has one (a sharded or partial fp16 set is not taken)."""
    by_path = {p.path: p for p in parts}
    defaults = [p for p in parts if p.path.endswith(".safetensors") and not _variant(p.path.rsplit("/", 1)[1])]
    copies = {}
    for d in defaults:
        half = by_path.get(d.path[:-len(".safetensors")] + ".fp16.safetensors")
        if half is None:
            return {}
        copies[d.path] = half
    return copies


def _loaded(parts: list[RemoteFile], half: bool) -> list[RemoteFile]:
    """Of one folder's files, those loaded: the weights' default variant, in safetensors where there is one (else
    the .bin); where half, the fp16 copies (_half_copies) under the default names."""
    names = [p.path.rsplit("/", 1)[-1] for p in parts]
    has_safetensors = any(n.endswith(".safetensors") and not _variant(n) for n in names)
    copies = _half_copies(parts) if half else {}
    chosen = []
    for part, name in zip(parts, names):
        if _variant(name) or (has_safetensors and name.endswith(".bin")):
            continue
        copy = copies.get(part.path)
        chosen.append(replace(copy, local=part.path) if copy else part)
    return chosen


def select_files(files: list[RemoteFile], index: dict, half: bool = False) -> list[RemoteFile]:
    """The files from_pretrained loads: model_index.json and its components' folders; of the weights, the
    default variant in safetensors where the folder has it (else the .bin). half: where a component has fp16
    copies of its weights, those instead, under the default names (half the download; a device that runs
    float32 loads them too, converted)."""
    wanted = set(pf.components(index))
    by_folder: dict[str, list[RemoteFile]] = {}
    chosen = [f for f in files if f.path == "model_index.json"]
    for f in files:
        top, _, rest = f.path.partition("/")
        if top in wanted and rest and "/" not in rest and not rest.endswith(SKIP_SUFFIXES):
            by_folder.setdefault(top, []).append(f)
    for top, parts in sorted(by_folder.items()):
        chosen += _loaded(parts, half)
    return chosen


def select_model_files(files: list[RemoteFile], half: bool = False) -> list[RemoteFile]:
    """One diffusers model's files (the catalogue's MODEL layout): config.json and the weights at the repository's
    root, chosen as a pipeline component's are (safetensors over .bin, the fp16 copies where half)."""
    root = [f for f in files if "/" not in f.path and f.path != "config.json" and not f.path.endswith(SKIP_SUFFIXES)
            and f.path.endswith(pf.WEIGHT_SUFFIXES)]
    return [f for f in files if f.path == "config.json"] + _loaded(root, half)


@dataclass
class DownloadOutcome:
    key: str
    folder: str
    files: int
    bytes_total: int
    bytes_fetched: int  # over the network this time (less than the total after a resume)
    resumed_files: int  # files continued from a .part (a stopped download, a broken connection)
    seconds: float

    def line(self) -> str:
        return (f"{self.key} downloaded: {pf.human_size(self.bytes_total)} in {self.files} files, checked, at "
                f"{self.folder}")


def _open_part(path: str):
    """The .part file, for appending (a test replaces it to fill the disk)."""
    return open(path, "ab")


def _disk_full(root: str, need: int) -> ModelError:
    return ModelError(f"the disk is full: the model needs {pf.human_size(need)} more in {root}: free some space, or "
                      f"choose another models folder in the preferences")


def _hash_ok(path: str, remote: RemoteFile) -> bool:
    if remote.sha256:
        return pf.sha256_of(path) == remote.sha256
    if remote.git_oid:
        return pf.git_blob_sha1(path) == remote.git_oid
    return True  # a hub that gives no hash: the size was checked


class Downloader:
    """One model's download; report(fraction, message) after each chunk; cancel_event stops it."""

    def __init__(self, hub: Hub, entry: CatalogueModel, root: str, report: Callable[[float, str], None] | None = None,
                 cancel_event: threading.Event | None = None, revision: str = "main", half: bool = False):
        self.hub, self.entry, self.root, self.revision = hub, entry, os.path.abspath(root), revision
        self.half = half
        self.report = report or (lambda fraction, message: None)
        self.cancel_event = cancel_event or threading.Event()
        self.partial = partial_folder(self.root, entry.key)
        self.total = self.done = self.fetched = 0
        self.resumed = 0
        self._said_at = 0.0

    def _check_cancel(self):
        if self.cancel_event.is_set():
            raise DownloadCancelled()

    def _say(self, path: str, size: int, here: int):
        share = self.done / self.total if self.total else 0.0  # model_index.json comes before the total is known
        self.report(0.98 * share, f"{path.rsplit('/', 1)[-1]}: {here / max(size, 1):.0%} of {size / 1e6:.0f} MB "
                           f"({pf.human_size(self.done)} of {pf.human_size(self.total)})")

    def run(self) -> DownloadOutcome:
        started = time.perf_counter()
        self.report(0.0, f"listing the files of {self.entry.repo_id}")
        listing = self.hub.list_files(self.entry.repo_id, self.revision)
        one_model = self.entry.layout == MODEL
        index_name = "config.json" if one_model else "model_index.json"
        index_file = next((f for f in listing if f.path == index_name), None)
        if index_file is None:
            what = "diffusers model" if one_model else "diffusers pipeline"
            raise ModelError(f"'{self.entry.repo_id}' is not a {what}: it has no {index_name}")
        os.makedirs(self.partial, exist_ok=True)
        self._fetch(index_file)
        if one_model:
            files = select_model_files(listing, self.half)
        else:
            files = select_files(listing, pf.read_index(self.partial), self.half)
        self.total = sum(f.size for f in files)
        self.done = sum(self._have(f) for f in files)
        _write_json(os.path.join(self.partial, pf.PLAN), {"repo_id": self.entry.repo_id, "bytes_total": self.total,
                                                          "files": len(files)})  # a stopped download's row says it
        free = shutil.disk_usage(self.root).free
        if free < self.total - self.done:
            raise _disk_full(self.root, self.total - self.done - free)
        for f in files:
            self._check_cancel()
            self._fetch(f)
        self.report(0.99, "checking the model" if one_model else "checking the pipeline")
        pf.check_layout(self.partial, self.entry.layout)
        manifest = {"repo_id": self.entry.repo_id, "revision": self.revision, "key": self.entry.key,
                    "files": {f.local_path: {"size": f.size, "source": f.path, "sha256": f.sha256 or pf.sha256_of(
                        os.path.join(self.partial, f.local_path))} for f in files}}
        _write_json(os.path.join(self.partial, pf.MANIFEST), manifest)
        os.remove(os.path.join(self.partial, pf.PLAN))
        final = model_folder(self.root, self.entry.key)
        replace_folder(self.partial, final)
        return DownloadOutcome(self.entry.key, final, len(files), self.total, self.fetched, self.resumed,
                               round(time.perf_counter() - started, 2))

    def _have(self, f: RemoteFile) -> int:
        """Bytes of f already here (a whole file, or its .part)."""
        path = os.path.join(self.partial, f.local_path)
        for candidate in (path, path + ".part"):
            if os.path.isfile(candidate):
                return min(os.path.getsize(candidate), f.size)
        return 0

    def _fetch(self, f: RemoteFile):
        path = os.path.join(self.partial, f.local_path)
        if os.path.isfile(path) and os.path.getsize(path) == f.size and _hash_ok(path, f):
            return  # verified by an earlier try
        if os.path.isfile(path):
            os.remove(path)
        part = path + ".part"
        os.makedirs(os.path.dirname(part), exist_ok=True)
        if os.path.isfile(part) and os.path.getsize(part) > f.size:
            os.remove(part)  # longer than the file: not ours
        if os.path.isfile(part) and os.path.getsize(part) > 0:
            self.resumed += 1
        for attempt in range(RETRIES + 1):
            try:
                self._stream(f, part)
                break
            except (http.client.IncompleteRead, ConnectionError, socket.timeout, TimeoutError) as exc:
                if attempt == RETRIES:
                    raise ModelError(f"the connection to {self.hub.base} broke {RETRIES + 1} times while "
                                     f"downloading {f.path} ({type(exc).__name__}): press Download again to "
                                     f"resume") from None
                self.resumed += 1
                time.sleep(0.2 * (attempt + 1))
        if os.path.getsize(part) != f.size or not _hash_ok(part, f):
            got = os.path.getsize(part)
            os.remove(part)
            kind = "sha256" if f.sha256 else "git hash"
            raise ModelError(f"{f.path} arrived damaged ({got} bytes, its {kind} does not match the repository's): "
                             f"it was deleted; press Download again")
        os.replace(part, path)

    def _stream(self, f: RemoteFile, part: str):
        start = os.path.getsize(part) if os.path.isfile(part) else 0
        if start == f.size:
            return
        with self.hub.open_file(self.entry.repo_id, f.path, start, self.revision) as response:
            if start and response.status != 206:  # the hub sends the whole file: start again
                self.done -= start
                start = 0
                with open(part, "wb"):
                    pass
            with _open_part(part) as out:
                here, first = start, True
                while True:
                    self._check_cancel()
                    block = response.read1(CHUNK)  # what has come: progress and cancel between packets
                    if not block:
                        break
                    try:
                        out.write(block)
                    except OSError as exc:
                        if exc.errno == errno.ENOSPC:
                            raise _disk_full(self.root, self.total - self.done) from None  # what is still to come
                        raise
                    here += len(block)
                    self.done += len(block)
                    self.fetched += len(block)
                    now = time.monotonic()
                    if first or here == f.size or now - self._said_at >= REPORT_S:  # not a line per packet
                        self._said_at, first = now, False
                        self._say(f.path, f.size, here)
        if os.path.getsize(part) < f.size:  # the connection ended early: the caller resumes from here
            raise http.client.IncompleteRead(b"", f.size - os.path.getsize(part))


def _write_json(path: str, value):
    with open(path + ".tmp", "w", encoding="utf-8") as out:
        json.dump(value, out, indent=1)
    os.replace(path + ".tmp", path)


def replace_folder(source: str, dest: str):
    """Rename source to dest; an old dest (a damaged model) goes aside first and is removed after."""
    trash = None
    if os.path.lexists(dest):
        trash = f"{dest}.old-{os.getpid()}-{int(time.time())}"
        os.replace(dest, trash)
    os.replace(source, dest)
    if trash:
        shutil.rmtree(trash, ignore_errors=True)


def remove_model(root: str, key: str) -> bool:
    """Delete a downloaded model and what a stopped download left; True where there was something."""
    if not os.path.isdir(root):
        return False
    with FolderLock(root, f"LAPIG: removing {key}"):  # never under a download of another Blender
        return _remove_folders(root, key)


def _remove_folders(root: str, key: str) -> bool:
    found = False
    for path in (model_folder(root, key), partial_folder(root, key)):
        if os.path.isdir(path):
            found = True
            aside = f"{path}.removing-{os.getpid()}"
            os.replace(path, aside)  # gone from its name at once, then deleted
            shutil.rmtree(aside, ignore_errors=True)
    return found


def download(entry: CatalogueModel, root: str, online_access: bool, base: str = "", token: str = "",
             report=None, cancel_event=None, overridden: bool = False, half: bool = False) -> DownloadOutcome:
    """The whole download, refused before any request where Blender does not allow online access. half: take
    the repository's fp16 copies of the weights where it has them (for a device that runs half precision)."""
    refusal = online_refusal(online_access, overridden)
    if refusal:
        raise ModelError(refusal)
    root = os.path.abspath(os.path.expanduser(root or ""))
    try:
        os.makedirs(root, exist_ok=True)
    except OSError as exc:
        raise ModelError(f"cannot make the models folder {root} ({exc.strerror}): choose another in the "
                         f"preferences") from None
    with FolderLock(root, f"LAPIG: downloading {entry.title}"):  # another Blender downloading here: refused
        return Downloader(Hub(base, token), entry, root, report, cancel_event, half=half).run()
