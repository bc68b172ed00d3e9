# SPDX-License-Identifier: GPL-3.0-or-later
"""The diffusion model manager against a local hub (tools/bench/fake_model_hub) serving a tiny random pipeline built
here: listing, download with progress, cancel and resume, a broken connection resumed, a damaged file found by its
hash, online access off, a full disk, an unknown model, a folder that is not a pipeline, a refused token; then the
downloaded folder loaded on the CPU and one step run through the InstructPix2Pix backend."""
from __future__ import annotations

import errno
import re
import io
import os
import threading
from dataclasses import replace

import pytest

pytest.importorskip("diffusers")
pytest.importorskip("transformers")

from lapig.lapig_core.diffusion import catalogue, device_fit, fetch, pipeline_folder as pf
from lapig.lapig_core.diffusion.catalogue import ModelError
from lapig.lapig_core.diffusion.hub import Hub, endpoint
from lapig.tools.bench.fake_model_hub import FakeModelHub
from lapig.tools.bench.tiny_pipeline import make_tiny_pipeline

UNET = "unet/diffusion_pytorch_model.safetensors"
ENTRY = replace(catalogue.model("instruct-pix2pix"), repo_id="tiny/ip2p")


@pytest.fixture(scope="module")
def tiny_repo(tmp_path_factory):
    folder = tmp_path_factory.mktemp("repo") / "tiny-ip2p"
    make_tiny_pipeline(folder, "ip2p")
    (folder / "unet" / "diffusion_pytorch_model.bin").write_bytes(b"old format: never fetched")
    (folder / "instruct-pix2pix-00-22000.ckpt").write_bytes(b"root checkpoint: never fetched")
    (folder / "README.md").write_text("model card")
    return str(folder)


@pytest.fixture
def hub(tiny_repo):
    with FakeModelHub({"tiny/ip2p": tiny_repo}) as served:
        yield served


def _download(hub, root, **kw):
    seen = []
    kw.setdefault("report", lambda fraction, message: seen.append((fraction, message)))
    outcome = fetch.download(kw.pop("entry", ENTRY), str(root), online_access=kw.pop("online", True), base=hub.url,
                             **kw)
    return outcome, seen


def test_the_catalogue_names_each_model_with_its_licence_and_refuses_an_unknown_one():
    assert catalogue.keys() == ["instruct-pix2pix", "sd-turbo", "depth-adapter"]
    ip2p = catalogue.model("timbrooks/instruct-pix2pix")
    assert ip2p.key == "instruct-pix2pix" and ip2p.kind == "ip2p" and "MIT" in ip2p.licence
    turbo = catalogue.model("sd-turbo")
    assert turbo.kind == "img2img" and "Stability AI Non-Commercial Research Community License" in turbo.licence
    with pytest.raises(ModelError, match="unknown model 'sdxl': the add-on supports instruct-pix2pix, sd-turbo, "
                                         "depth-adapter"):
        catalogue.model("sdxl")
    assert endpoint("", {"HF_ENDPOINT": "http://mirror:8080/"}) == "http://mirror:8080"
    assert endpoint("http://set", {"HF_ENDPOINT": "http://env"}) == "http://set"
    assert endpoint("", {}) == "https://huggingface.co"


def test_the_listing_follows_pages_and_gives_sizes_and_hashes(hub, tiny_repo):
    files = Hub(hub.url).list_files("tiny/ip2p")
    assert len(files) == len(hub.listing("tiny/ip2p")) > hub.page_size  # more than one page
    unet = next(f for f in files if f.path == UNET)
    assert unet.size == os.path.getsize(os.path.join(tiny_repo, UNET))
    assert unet.sha256 == pf.sha256_of(os.path.join(tiny_repo, UNET))
    index = next(f for f in files if f.path == "model_index.json")
    assert index.sha256 is None and index.git_oid == pf.git_blob_sha1(os.path.join(tiny_repo, "model_index.json"))


def test_a_download_reports_progress_checks_every_file_and_appears_only_when_whole(hub, tmp_path):
    root = tmp_path / "models"
    outcome, seen = _download(hub, root)
    folder = root / "instruct-pix2pix"
    assert outcome.folder == str(folder) and outcome.resumed_files == 0
    state = pf.folder_state(str(folder))
    assert state.state == pf.READY, state.why
    assert not (folder / "unet" / "diffusion_pytorch_model.bin").exists()  # the safetensors only
    assert not (folder / "instruct-pix2pix-00-22000.ckpt").exists() and not (folder / "README.md").exists()
    assert (folder / pf.MANIFEST).is_file() and pf.verify(str(folder)) == []
    assert not (root / ".partial-instruct-pix2pix").exists()
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] >= 0.99
    assert any("diffusion_pytorch_model.safetensors: 100% of" in m for _, m in seen), seen
    assert outcome.bytes_total == outcome.bytes_fetched == sum(e["size"] for e in
                                                               pf.read_manifest(str(folder))["files"].values())


def test_a_cancel_leaves_nothing_that_looks_ready_and_the_next_download_resumes(hub, tmp_path):
    root = tmp_path / "models"
    hub.slow_s = 0.05
    cancel = threading.Event()

    def report(fraction, message):
        if UNET.rsplit("/", 1)[1] in message and "100%" not in message:
            cancel.set()  # mid-UNet

    with pytest.raises(fetch.DownloadCancelled):
        fetch.download(ENTRY, str(root), True, base=hub.url, report=report, cancel_event=cancel)
    partial = fetch.partial_folder(str(root), ENTRY.key)
    assert pf.folder_state(str(root / "instruct-pix2pix"), partial).state == pf.ABSENT
    part = root / ".partial-instruct-pix2pix" / (UNET + ".part")
    kept = part.stat().st_size
    assert 0 < kept < os.path.getsize(os.path.join(hub.repos["tiny/ip2p"], UNET))
    state = pf.folder_state(str(root / "instruct-pix2pix"), str(root / ".partial-instruct-pix2pix"))
    assert re.match(r"a download stopped after 0\.\d MB of 0\.4 MB: Download resumes it$", state.why), state.why
    hub.slow_s = 0.0
    hub.requests.clear()
    outcome, _ = _download(hub, root)
    assert outcome.resumed_files >= 1 and outcome.bytes_fetched < outcome.bytes_total
    assert hub.file_requests(UNET)[0][1] == f"bytes={kept}-"  # HTTP Range from where it stopped
    assert pf.verify(outcome.folder) == [] and pf.folder_state(outcome.folder).state == pf.READY


def test_a_connection_killed_mid_file_is_resumed_from_where_it_broke(hub, tmp_path):
    hub.kill_once.add(UNET)
    outcome, _ = _download(hub, tmp_path / "models")
    ranges = [r[1] for r in hub.file_requests(UNET)]
    assert ranges[0] == "" and ranges[1].startswith("bytes=") and int(ranges[1][6:-1]) > 0, ranges
    assert outcome.resumed_files == 1 and pf.verify(outcome.folder) == []


def test_a_damaged_file_is_found_by_its_hash_and_never_kept(hub, tmp_path):
    root = tmp_path / "models"
    hub.corrupt.add(UNET)
    with pytest.raises(ModelError, match=r"^unet/diffusion_pytorch_model.safetensors arrived damaged .*sha256 does "
                                         r"not match the repository's"):
        _download(hub, root)
    assert not (root / "instruct-pix2pix").exists()
    assert not (root / ".partial-instruct-pix2pix" / UNET).exists()
    assert not (root / ".partial-instruct-pix2pix" / (UNET + ".part")).exists()
    hub.corrupt.clear()  # the hub is mended: the next download fetches the UNet again, and the rest stays
    outcome, _ = _download(hub, root)
    assert pf.folder_state(outcome.folder).state == pf.READY


def test_a_model_damaged_on_disk_says_so(hub, tmp_path):
    outcome, _ = _download(hub, tmp_path / "models")
    with open(os.path.join(outcome.folder, UNET), "r+b") as f:
        f.truncate(100)
    state = pf.folder_state(outcome.folder)
    assert state.state == pf.DAMAGED and state.why.startswith(f"{UNET} has 100 bytes") and "Remove it" in state.why
    assert fetch.remove_model(str(tmp_path / "models"), ENTRY.key)
    assert pf.folder_state(outcome.folder).state == pf.ABSENT


def test_a_second_download_into_the_same_folder_is_refused_while_one_runs(hub, tmp_path):
    from lapig.lapig_core.common.locking import FolderLock

    root = tmp_path / "models"
    with FolderLock(root, "LAPIG: downloading SD-Turbo"):  # another Blender's download
        with pytest.raises(OSError, match=r"models is in use by LAPIG: downloading SD-Turbo \(pid \d+"):
            _download(hub, root)
        with pytest.raises(OSError, match="in use by LAPIG: downloading SD-Turbo"):
            fetch.remove_model(str(root), ENTRY.key)
    assert hub.requests == []
    outcome, _ = _download(hub, root)
    assert not (root / ".lapig.lock").exists() and pf.folder_state(outcome.folder).state == pf.READY


def test_online_access_off_is_refused_before_any_request(hub, tmp_path):
    with pytest.raises(ModelError, match=r"^Online access is off in Blender: allow it in Preferences > System > "
                                         r"Network"):
        _download(hub, tmp_path / "models", online=False)
    assert hub.requests == [] and not (tmp_path / "models").exists()
    assert "--offline-mode" in fetch.online_refusal(False, overridden=True)


def test_a_full_disk_is_one_line_and_keeps_what_was_written(hub, tmp_path, monkeypatch):
    class Full(io.BytesIO):
        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(fetch, "_open_part", lambda path: Full())
    with pytest.raises(ModelError, match=r"^the disk is full: the model needs .* [MG]B more in .*models: free some "
                                         r"space, or choose another models folder"):
        _download(hub, tmp_path / "models")
    assert not (tmp_path / "models" / "instruct-pix2pix").exists()
    monkeypatch.setattr(fetch.shutil, "disk_usage", lambda path: os.statvfs_result((0,) * 10) and
                        type("U", (), {"free": 10})())
    with pytest.raises(ModelError, match="the disk is full"):  # found before downloading: the listing's total
        _download(hub, tmp_path / "models")


def test_an_unknown_repository_a_refused_token_and_a_gated_model_are_one_line_each(tiny_repo, tmp_path):
    with FakeModelHub({"tiny/ip2p": tiny_repo}, token="right") as hub:
        with pytest.raises(ModelError, match=r"has no model 'nobody/nothing' \(HTTP 404\): check its name"):
            _download(hub, tmp_path / "m", entry=replace(ENTRY, repo_id="nobody/nothing"))
        with pytest.raises(ModelError, match=r"^the hub refused the token for 'tiny/ip2p' \(HTTP 401\): check the "
                                             r"Hub token"):
            _download(hub, tmp_path / "m", token="wrong")
        with pytest.raises(ModelError, match=r"needs a token \(HTTP 401\)"):
            _download(hub, tmp_path / "m")
        hub.requests.clear()
        outcome, _ = _download(hub, tmp_path / "m", token="right")
        assert pf.folder_state(outcome.folder).state == pf.READY
        assert hub.requests and all(r[2] == "Bearer right" for r in hub.requests)
    with FakeModelHub({"tiny/ip2p": tiny_repo}, gated=True) as hub:
        with pytest.raises(ModelError, match=r"'tiny/ip2p' is gated: accept its licence on "
                                             r"https://huggingface.co/tiny/ip2p"):
            _download(hub, tmp_path / "g")


def test_a_half_precision_device_takes_the_fp16_copies_under_the_default_names(tmp_path):
    import torch
    from lapig.lapig_core.lgst import get_backend

    repo = make_tiny_pipeline(tmp_path / "repo", "ip2p", fp16_copies=True)
    with FakeModelHub({"tiny/ip2p": repo}) as hub:
        full, _ = _download(hub, tmp_path / "full")
        half, _ = _download(hub, tmp_path / "half", half=True)
    assert half.bytes_total < 0.6 * full.bytes_total
    manifest = pf.read_manifest(half.folder)["files"]
    assert manifest[UNET]["source"] == "unet/diffusion_pytorch_model.fp16.safetensors"
    assert not os.path.exists(os.path.join(half.folder, "unet", "diffusion_pytorch_model.fp16.safetensors"))
    assert device_fit._stored_half(half.folder) and not device_fit._stored_half(full.folder)
    assert pf.verify(half.folder) == [] and pf.folder_state(half.folder).state == pf.READY
    backend = get_backend("instruct-pix2pix", model=half.folder, size=64, steps=1, psa_steps=1, device="cpu")
    out = backend.stylize(torch.rand(1, 3, 64, 64), "Make it a Claymation")  # the CPU loads them as float32
    assert torch.isfinite(out).all() and backend.describe()["dtype"] == "float32"


def test_a_folder_that_is_not_a_pipeline_is_refused_with_what_it_lacks(tiny_repo, tmp_path):
    assert pf.check_pipeline(tiny_repo)["_class_name"] == "StableDiffusionInstructPix2PixPipeline"
    with pytest.raises(ModelError, match="has no model_index.json"):
        pf.check_pipeline(str(tmp_path))
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "model_index.json").write_text('{"unet": ["diffusers", "UNet2DConditionModel"], '
                                             '"vae": ["diffusers", "AutoencoderKL"]}')
    (broken / "unet").mkdir()
    (broken / "unet" / "config.json").write_text("{}")
    with pytest.raises(ModelError, match=r"lacks unet/ \(its weights\), vae/ \(its config\)"):
        pf.check_pipeline(str(broken))
    with pytest.raises(ModelError, match="not a StableDiffusionImg2ImgPipeline"):
        pf.check_pipeline(tiny_repo, "StableDiffusionImg2ImgPipeline")
    with pytest.raises(ModelError, match="no folder at"):
        pf.check_pipeline(str(tmp_path / "nowhere"))


def test_the_device_plan_takes_half_precision_on_gpus_and_says_when_it_does_not_fit(tiny_repo, monkeypatch):
    assert device_fit.half_precision("cuda") and device_fit.half_precision("mps")
    assert not device_fit.half_precision("cpu")
    monkeypatch.setattr(device_fit, "_loads_twice", lambda: False)  # accelerate installed
    cpu = device_fit.plan(3_400_000_000, "cpu", free_mb=2000.0)
    assert cpu.device == "cpu" and cpu.dtype == "float32" and not cpu.fits
    assert cpu.line("InstructPix2Pix").startswith("InstructPix2Pix does not fit on the CPU: it needs about 5.4 GB "
                                                  "in float32, 2.0 GB free")
    monkeypatch.setattr(device_fit, "_loads_twice", lambda: True)  # without it, loading holds two copies
    assert "it needs about 7.8 GB" in device_fit.plan(3_400_000_000, "cpu", free_mb=2000.0).line()
    assert device_fit.needed_mb(2 ** 30, "float16", "cuda") < device_fit.needed_mb(2 ** 30, "float32", "cuda")
    with pytest.raises(ModelError, match="does not fit on the CPU"):
        device_fit.require_fit(tiny_repo, "cpu", free_mb=100.0)
    ok = device_fit.require_fit(tiny_repo, "cpu")  # the machine's own free memory: the tiny one fits
    assert ok.fits and ok.free_mb and "runs on the CPU in float32" in ok.line()


def test_auto_takes_a_gpu_in_half_precision_where_torch_sees_one(monkeypatch):
    import torch
    from lapig.lapig_core.common import compute_device

    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(compute_device, "short_name", lambda device: "CUDA (Test GPU)")
    gpu = device_fit.plan(3_400_000_000, "auto", free_mb=4000.0)
    assert gpu.device == "cuda" and gpu.dtype == "float16" and gpu.fits  # 3.4 GB of float32 weights: 2 GB as halves
    assert device_fit.plan(3_400_000_000, "cpu", free_mb=3000.0).dtype == "float32"  # the preference: the CPU
    small = device_fit.plan(3_400_000_000, "auto", free_mb=2500.0)
    assert small.line("InstructPix2Pix") == ("InstructPix2Pix does not fit on CUDA (Test GPU): it needs about 3.2 GB "
                                             "in float16, 2.4 GB free: close other programs or leave the GPU to "
                                             "Cycles and choose the CPU in the preferences")


def test_the_downloaded_pipeline_runs_one_step_through_the_ip2p_backend(hub, tmp_path):
    import torch
    from lapig.lapig_core.lgst import get_backend

    outcome, _ = _download(hub, tmp_path / "models")
    backend = get_backend("instruct-pix2pix", model=outcome.folder, size=64, steps=1, psa_steps=1, device="cpu")
    surface = torch.rand(1, 3, 64, 64, generator=torch.Generator().manual_seed(0))
    out = backend.stylize(surface, "Make it a Claymation")
    assert out.shape == (1, 3, 64, 64) and torch.isfinite(out).all() and out.std() > 0
    assert backend.describe()["dtype"] == "float32"


def test_the_one_step_model_downloads_and_previews_at_512_px(tmp_path):
    import torch
    from lapig.lapig_core.diffusion import one_step

    repo = make_tiny_pipeline(tmp_path / "repo", "img2img")
    with FakeModelHub({"tiny/turbo": repo}) as hub:
        outcome, _ = _download(hub, tmp_path / "models", entry=replace(catalogue.model("sd-turbo"),
                                                                        repo_id="tiny/turbo"))
    surface = torch.rand(1, 3, 96, 128, generator=torch.Generator().manual_seed(0))
    out = one_step.preview(outcome.folder, surface, "a stained glass window", size=512, choice="cpu")
    again = one_step.preview(outcome.folder, surface, "a stained glass window", size=512, choice="cpu")
    assert out.shape == (1, 3, 512, 512) and torch.isfinite(out).all() and torch.equal(out, again)  # seeded
    with pytest.raises(ModelError, match="needs a Stable Diffusion text-to-image or image-to-image pipeline"):
        one_step.preview(make_tiny_pipeline(tmp_path / "ip2p", "ip2p"), surface, "x", size=64, choice="cpu")
