# SPDX-License-Identifier: GPL-3.0-or-later
"""The preferences' model manager without Blender: the download as a job (progress, cancel, resume) in its slot,
each model's row (absent, downloading, ready, damaged), Use Folder and Remove, against the local hub."""
from __future__ import annotations

import importlib
import os
import time

import pytest

pytest.importorskip("diffusers")
pytest.importorskip("transformers")

from lapig.tools.bench.fake_model_hub import FakeModelHub
from lapig.tools.bench.tiny_pipeline import make_tiny_pipeline

UNET = "unet/diffusion_pytorch_model.safetensors"


@pytest.fixture(scope="module")
def tiny_repo(tmp_path_factory):
    return make_tiny_pipeline(tmp_path_factory.mktemp("repo") / "tiny-ip2p", "ip2p")


@pytest.fixture
def md():
    return importlib.import_module("lapig.lapig_addon.services.install.model_download")


@pytest.fixture
def hub(tiny_repo, md, monkeypatch):
    from lapig.lapig_core.diffusion import catalogue

    tiny = catalogue.CatalogueModel(key="instruct-pix2pix", repo_id="tiny/ip2p", title="InstructPix2Pix", kind="ip2p",
                                    licence="MIT", licence_url="", purpose="test")
    monkeypatch.setattr(catalogue, "CATALOGUE", (tiny,) + catalogue.CATALOGUE[1:])
    with FakeModelHub({"tiny/ip2p": tiny_repo}) as served:
        yield served


def _request(md, hub, root, online=True):
    return md.DownloadRequest("instruct-pix2pix", str(root), online, base=hub.url)


def test_the_download_job_moves_its_bar_and_the_row_turns_ready(md, hub, tmp_path):
    slot = md.DownloadSlot()
    root = tmp_path / "models"
    assert md.model_row("instruct-pix2pix", str(root), slot=slot).state == "absent"
    job = md.ModelDownloadJob(_request(md, hub, root))
    assert slot.start(job) == ""
    job.poll_timeout = 0.05
    rows = []
    while job.step():
        rows.append(md.model_row("instruct-pix2pix", str(root), slot=slot))
    slot.ended(job)
    assert job.state == "DONE", job.message
    assert rows and all(r.state == "downloading" for r in rows)
    assert any(r.line.startswith("diffusion_pytorch_model.safetensors: ") for r in rows), [r.line for r in rows]
    row = md.model_row("instruct-pix2pix", str(root), slot=slot)
    assert row.state == "ready" and row.line.startswith("ready: 0.4 MB at ") and slot.said[
        "instruct-pix2pix"][1].startswith("instruct-pix2pix downloaded: ")
    assert md.ready_folder("instruct-pix2pix", str(root)) == row.folder
    assert md.remove("instruct-pix2pix", str(root), slot) == f"InstructPix2Pix removed from {root}"
    assert md.model_row("instruct-pix2pix", str(root), slot=slot).state == "absent"


def test_a_cancel_from_the_panel_stops_the_worker_and_the_next_download_resumes(md, hub, tmp_path):
    slot = md.DownloadSlot()
    root = tmp_path / "models"
    hub.slow_s = 0.05
    job = md.ModelDownloadJob(_request(md, hub, root))
    slot.start(job)
    job.poll_timeout = 0.05
    deadline = time.monotonic() + 60
    part = root / ".partial-instruct-pix2pix" / (UNET + ".part")
    while not (part.exists() and part.stat().st_size > 0):
        assert job.step() and time.monotonic() < deadline, job.message
    assert slot.start(md.ModelDownloadJob(_request(md, hub, root))).endswith("(one download at a time)")
    assert slot.cancel()
    job.stop()  # the worker has seen it
    assert job.state == "CANCELLED" and "Download resumes it" in slot.said["instruct-pix2pix"][1]
    row = md.model_row("instruct-pix2pix", str(root), slot=slot)
    assert row.state == "absent" and "a download stopped after" in row.line
    kept = part.stat().st_size
    hub.slow_s = 0.0
    hub.requests.clear()
    again = md.ModelDownloadJob(_request(md, hub, root))
    assert slot.start(again) == ""
    again.poll_timeout = 0.05
    again.run()
    assert again.state == "DONE", again.message
    assert hub.file_requests(UNET)[0][1] == f"bytes={kept}-"
    assert again.result.resumed_files >= 1


def test_offline_an_unknown_model_a_foreign_folder_and_a_damaged_one_are_one_line_each(md, hub, tmp_path, tiny_repo):
    slot = md.DownloadSlot()
    refused = slot.start(md.ModelDownloadJob(_request(md, hub, tmp_path, online=False)))
    assert refused.startswith("Online access is off in Blender: allow it in Preferences > System > Network")
    assert slot.job is None and hub.requests == []
    with pytest.raises(ValueError, match="unknown model 'dall-e'"):
        md.ModelDownloadJob(md.DownloadRequest("dall-e", str(tmp_path), True))
    assert md.use_folder("instruct-pix2pix", tiny_repo) == tiny_repo
    with pytest.raises(ValueError, match="has no model_index.json"):
        md.use_folder("instruct-pix2pix", str(tmp_path))
    turbo = make_tiny_pipeline(tmp_path / "turbo", "img2img")
    with pytest.raises(ValueError, match="holds a StableDiffusionImg2ImgPipeline, not a "
                                         "StableDiffusionInstructPix2PixPipeline"):
        md.use_folder("instruct-pix2pix", turbo)
    row = md.model_row("instruct-pix2pix", str(tmp_path), own_folder=tiny_repo, slot=slot)
    assert row.state == "ready" and row.own_folder and row.line.startswith(f"ready: your folder {tiny_repo}")
    os.remove(os.path.join(turbo, UNET))
    row = md.model_row("sd-turbo", str(tmp_path), own_folder=turbo, slot=slot)
    assert row.state == "damaged" and "lacks unet/ (its weights)" in row.line
