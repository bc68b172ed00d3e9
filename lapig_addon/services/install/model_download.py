# SPDX-License-Identifier: GPL-3.0-or-later
"""The preferences' model manager without Blender: each catalogue model's state, and its download as a job.

The download is lapig_core/diffusion/fetch on a WorkerJob's thread (the job engine's progress and cancel, as
Install torch); one download at a time, in DOWNLOADS (a slot like torch_install's). A cancel stops it between
two network reads: the .part files stay, and the next Download resumes them. The state a row shows:
downloading (this slot's job), else the folder's own (absent, ready, damaged), where a folder of the user's
own ("Use Folder") stands in for the download.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from ....lapig_core.diffusion import catalogue, fetch
from ....lapig_core.diffusion import pipeline_folder as pf
from ..jobs import JobCancelled, WorkerJob

DOWNLOADING = "downloading"
CLASS_OF_KIND = {"ip2p": "StableDiffusionInstructPix2PixPipeline", "img2img": None, "depth-adapter": "T2IAdapter"}


@dataclass
class DownloadRequest:
    key: str
    root: str  # the models folder
    online_access: bool
    base: str = ""  # the hub's address ('' : HF_ENDPOINT, else huggingface.co)
    token: str = ""
    overridden: bool = False  # --offline-mode: the preference cannot turn it on
    device: str = "auto"  # the preferences' Device: a GPU that runs half precision takes the fp16 copies


class ModelDownloadJob(WorkerJob):
    title = "Downloading a model"

    def __init__(self, request: DownloadRequest):
        super().__init__()
        self.request = request
        self.entry = catalogue.model(request.key)  # an unknown key is refused before the job starts
        self.title = f"Downloading {self.entry.title}"

    def work(self, inputs, report, cancel_event):
        r = self.request
        try:
            return fetch.download(self.entry, r.root, r.online_access, r.base, r.token, report, cancel_event,
                                  r.overridden, half=runs_half(r.device))
        except fetch.DownloadCancelled:
            raise JobCancelled() from None


def runs_half(choice: str) -> bool:
    """Whether the device the models would run on takes half precision (on the worker: it imports torch)."""
    try:
        from ....lapig_core.common import compute_device
        from ....lapig_core.diffusion.device_fit import half_precision
    except ImportError:  # no torch yet: the full-precision files, which every device loads
        return False
    return half_precision(compute_device.resolve(choice).type)


class DownloadSlot:
    """The one model download of a session, and what the last one said (per model)."""

    def __init__(self):
        self.job: ModelDownloadJob | None = None
        self.said: dict[str, tuple[str, str]] = {}  # key -> (icon kind 'DONE'/'FAILED'/'CANCELLED', line)

    def running(self, key: str | None = None) -> bool:
        busy = self.job is not None and not self.job.finished
        return busy and (key is None or self.job.request.key == key)

    def start(self, job: ModelDownloadJob) -> str:
        if self.running():
            return (f"{self.job.entry.title} is downloading: wait for it, or Cancel it (one download at a time)")
        refusal = fetch.online_refusal(job.request.online_access, job.request.overridden)
        if refusal:
            return refusal
        self.job = job
        self.said.pop(job.request.key, None)
        return ""

    def ended(self, job: ModelDownloadJob):
        key = job.request.key
        if job.state == "DONE":
            self.said[key] = ("DONE", job.result.line())
        elif job.state == "FAILED":
            self.said[key] = ("FAILED", f"Downloading {job.entry.title} failed: {job.message}")
        elif job.state == "CANCELLED":
            self.said[key] = ("CANCELLED", f"Downloading {job.entry.title} was cancelled: Download resumes it; "
                                           f"nothing half-downloaded is used")

    def cancel(self) -> bool:
        if not self.running():
            return False
        self.job.cancel()  # the worker stops at its next read; the .part files stay for a resume
        self.ended(self.job)
        return True


DOWNLOADS = DownloadSlot()


@dataclass
class ModelRow:
    """One model's row in the preferences."""
    entry: catalogue.CatalogueModel
    state: str  # absent, downloading, ready, damaged
    folder: str  # where it is (or would go)
    line: str  # the state in words: size, where, why
    progress: float = 0.0
    own_folder: bool = False  # the user's folder (Use Folder), not a download


def _gb(n: int) -> str:
    return pf.human_size(n)


def model_row(key: str, root: str, own_folder: str = "", slot: DownloadSlot = DOWNLOADS) -> ModelRow:
    entry = catalogue.model(key)
    if slot.running(key):
        job = slot.job
        return ModelRow(entry, DOWNLOADING, fetch.model_folder(root, key), job.message, job.progress)
    if own_folder:
        try:
            pf.check_layout(own_folder, entry.layout, CLASS_OF_KIND.get(entry.kind))
        except catalogue.ModelError as exc:
            return ModelRow(entry, pf.DAMAGED, own_folder, str(exc), own_folder=True)
        size = pf.weights_bytes(own_folder)
        return ModelRow(entry, pf.READY, own_folder, f"ready: your folder {own_folder} ({_gb(size)} of weights)",
                        own_folder=True)
    folder = fetch.model_folder(root, key)
    state = pf.folder_state(folder, fetch.partial_folder(root, key), entry.layout)
    if state.state == pf.READY:
        line = f"ready: {_gb(state.size_bytes)} at {folder}"
    elif state.state == pf.DAMAGED:
        line = f"damaged: {state.why}"
    else:
        size = entry.size_hint or "listed when the download starts"
        line = f"absent{': ' + state.why if state.why else ''} (size: {size})"
    return ModelRow(entry, state.state, folder, line)


def ready_folder(key: str, root: str, own_folder: str = "") -> str:
    """The folder to load the model from ('' where it is not ready)."""
    row = model_row(key, root, own_folder)
    return row.folder if row.state == pf.READY else ""


def use_folder(key: str, folder: str) -> str:
    """The user's folder for a model, checked to be a pipeline of its kind; ModelError otherwise."""
    entry = catalogue.model(key)
    folder = os.path.abspath(os.path.expanduser(folder or ""))
    pf.check_layout(folder, entry.layout, CLASS_OF_KIND.get(entry.kind))
    return folder


def remove(key: str, root: str, slot: DownloadSlot = DOWNLOADS) -> str:
    """Delete the downloaded model (and a stopped download's files): its line."""
    entry = catalogue.model(key)
    if slot.running(key):
        return f"{entry.title} is downloading: Cancel it first"
    if fetch.remove_model(root, key):
        slot.said.pop(key, None)
        return f"{entry.title} removed from {root}"
    return f"{entry.title} is not in {root}: nothing to remove"
