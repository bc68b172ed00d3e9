# SPDX-License-Identifier: GPL-3.0-or-later
"""`python -m lapig_addon bench diffusion --json`: the diffusion model manager's chain against a local hub (issue 53).

A tiny InstructPix2Pix pipeline and a tiny one-step img2img pipeline (random weights, about 0.4 MB each, built
here; the one-step one with fp16 copies, which a GPU's download takes) are served by tools/bench/fake_model_hub
as a Hugging Face hub would serve them; the manager downloads them
into a fresh models folder. Each *_ok is true only when its check ran and held:
  * download_ok: the download reported progress, every file matches its listed sha256 / git hash, the folder is
    a whole pipeline and ready, and no partial folder is left;
  * resume_ok: a connection dropped mid-file is resumed with an HTTP Range from where it broke, and a cancelled
    download is resumed by the next one from its .part file (the hub sees bytes=N-);
  * hash_check_ok: a file the hub sends damaged is refused by its sha256, and nothing looks ready;
  * offline_refused_ok: with Blender's online access off the download is refused before any request.
Then the downloaded pipelines run on the device the manager picks: preview_seconds is the fast path's preview of one
prompt at 512 px (the 'one-step' look's one UNet call, services/generate/prompt_preview; after a warm-up call, the load
excluded), pipeline_preview_seconds the same model through diffusers' img2img pipeline (one_step.preview), ip2p_seconds_512 one InstructPix2Pix stylize (2 steps) at 512 px
through the LGST backend; peak_memory_mb the process's peak resident memory (CUDA: the allocator's peak).
A tiny depth adapter (T2I-Adapter, random weights) is downloaded as the catalogue's depth-adapter; then
  * depth_conditioned_ok: the InstructPix2Pix look at 512 px with the adapter is the same image for the same depth
    and seed, another for another depth (a ball before a wall, a leaning wall), and not the look without it;
  * psa_seconds: PSA (PSA_SETTINGS: a short run, its iterations in psa_iterations) on that depth-conditioned look at
    512 px, against random CompenNeSt/PCNet networks (the time of the steps, not of a good adaptation).
"""
from __future__ import annotations

import os
import resource
import sys
import tempfile
import threading
import time
from dataclasses import replace

UNET = "unet/diffusion_pytorch_model.safetensors"
PSA_STEPS = {"max_iterations": 3, "warm_start_steps": 4}  # PSA_SETTINGS: a short run, for its time per step


def _peak_rss_mb() -> float:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2 ** 20 if sys.platform == "darwin" else peak / 1024  # bytes on macOS, kB on Linux


def _checks(hub, work: str, ip2p_entry) -> dict:
    from ...lapig_core.diffusion import fetch
    from ...lapig_core.diffusion import pipeline_folder as pf
    from ...lapig_core.diffusion.catalogue import ModelError

    out = {}
    seen = []
    root = os.path.join(work, "download")
    outcome = fetch.download(ip2p_entry, root, True, hub.url, report=lambda f, m: seen.append(f))
    out["download_ok"] = (pf.folder_state(outcome.folder).state == pf.READY and pf.verify(outcome.folder) == []
                          and len(seen) > 3 and seen == sorted(seen)
                          and not os.path.exists(fetch.partial_folder(root, ip2p_entry.key)))
    out["download_seconds"] = outcome.seconds
    out["download_bytes"] = outcome.bytes_total

    # a connection dropped mid-file, then a cancel and a second download
    hub.kill_once.add(UNET)
    hub.requests.clear()
    killed = fetch.download(ip2p_entry, os.path.join(work, "killed"), True, hub.url)
    ranges = [r[1] for r in hub.file_requests(UNET)]
    killed_ok = (len(ranges) == 2 and ranges[1].startswith("bytes=") and int(ranges[1][6:-1]) > 0
                 and pf.verify(killed.folder) == [])
    hub.slow_s = 0.02
    cancel = threading.Event()
    cancelled = False
    root = os.path.join(work, "cancelled")
    try:
        fetch.download(ip2p_entry, root, True, hub.url, cancel_event=cancel,
                       report=lambda f, m: cancel.set() if UNET.rsplit("/", 1)[1] in m and "100%" not in m else None)
    except fetch.DownloadCancelled:
        cancelled = True
    hub.slow_s = 0.0
    part = os.path.join(fetch.partial_folder(root, ip2p_entry.key), UNET + ".part")
    kept = os.path.getsize(part) if os.path.isfile(part) else 0
    hub.requests.clear()
    again = fetch.download(ip2p_entry, root, True, hub.url)
    first = hub.file_requests(UNET)
    cancel_ok = (cancelled and kept > 0 and bool(first) and first[0][1] == f"bytes={kept}-"
                 and pf.verify(again.folder) == [])
    out["resume_ok"] = killed_ok and cancel_ok

    hub.corrupt.add(UNET)
    root = os.path.join(work, "corrupt")
    try:
        fetch.download(ip2p_entry, root, True, hub.url)
        out["hash_check_ok"] = False
    except ModelError as exc:
        out["hash_check_ok"] = ("arrived damaged" in str(exc)
                                and not os.path.exists(os.path.join(root, ip2p_entry.key)))
        out["hash_check_line"] = str(exc)
    hub.corrupt.clear()

    hub.requests.clear()
    try:
        fetch.download(ip2p_entry, os.path.join(work, "offline"), False, hub.url)
        out["offline_refused_ok"] = False
    except ModelError as exc:
        out["offline_refused_ok"] = str(exc).startswith("Online access is off") and hub.requests == []
    return out


def _runs(ip2p_folder: str, turbo_folder: str, device: str) -> dict:
    import torch

    from ...lapig_core.diffusion import device_fit, one_step
    from ...lapig_core.lgst import get_backend

    out = {}
    plan = device_fit.require_fit(turbo_folder, device, "the one-step model")
    out["device"] = plan.name
    out["dtype"] = plan.dtype
    out["device_line"] = plan.line("the tiny one-step model")
    surface = torch.rand(1, 3, 512, 512, generator=torch.Generator().manual_seed(0))
    started = time.perf_counter()
    one_step.preview(turbo_folder, surface, "a stained glass window", size=512, choice=device)
    out["load_and_first_preview_seconds"] = round(time.perf_counter() - started, 3)
    started = time.perf_counter()
    image = one_step.preview(turbo_folder, surface, "a stained glass window", size=512, choice=device, seed=1)
    out["pipeline_preview_seconds"] = round(time.perf_counter() - started, 3)
    look = get_backend("one-step", model=turbo_folder, size=512, device=device)  # the fast path's look
    look.stylize(surface, "a stained glass", seed=1)  # its first call
    started = time.perf_counter()
    fast = look.stylize(surface, "a stained glass window", seed=1)
    out["preview_seconds"] = round(time.perf_counter() - started, 3)
    out["preview_ok"] = all(tuple(i.shape) == (1, 3, 512, 512) and bool(torch.isfinite(i).all()) for i in (image, fast))
    backend = get_backend("instruct-pix2pix", model=ip2p_folder, size=512, steps=2, psa_steps=1, device=device)
    backend.stylize(surface, "Make it a Claymation")  # the load
    started = time.perf_counter()
    styled = backend.stylize(surface, "Make it a Claymation", seed=1)
    out["ip2p_seconds_512"] = round(time.perf_counter() - started, 3)
    out["ip2p_ok"] = tuple(styled.shape) == (1, 3, 512, 512) and bool(torch.isfinite(styled).all())
    if torch.cuda.is_available() and plan.device == "cuda":
        out["peak_memory_mb"] = round(torch.cuda.max_memory_allocated() / 2 ** 20, 1)
        out["peak_memory_kind"] = "CUDA allocator peak"
    else:
        out["peak_memory_mb"] = round(_peak_rss_mb(), 1)
        out["peak_memory_kind"] = "process peak resident memory"
    return out


def _depth_runs(ip2p_folder: str, depth_folder: str, device: str) -> dict:
    """depth_conditioned_ok and psa_seconds (module docstring)."""
    import torch

    from ...lapig_core.lgst import get_backend
    from ...lapig_core.photometric.checkpoints import new_model
    from ...lapig_core.photometric.surface_models import SurfaceModels
    from ...lapig_core.psa.adaptation import PSASettings, run_psa
    from .tiny_pipeline import tiny_geometry

    surface = torch.rand(1, 3, 512, 512, generator=torch.Generator().manual_seed(0))
    shapes = {shape: tiny_geometry(512, 512, shape) for shape in ("ball", "slope")}

    def look(geometry, adapter=True):
        backend = get_backend("instruct-pix2pix", model=ip2p_folder, size=512, steps=2, psa_steps=1, device=device,
                              depth_adapter=depth_folder if adapter else None, geometry=geometry)
        return backend.stylize(surface, "Make it a stained glass artwork", seed=1), backend

    ball, backend = look(shapes["ball"])
    same = look(shapes["ball"])[0]
    slope = look(shapes["slope"])[0]
    plain = look(shapes["ball"], adapter=False)[0]
    moved = float((ball - slope).abs().mean())
    out = {"depth_conditioned_ok": bool(torch.equal(ball, same) and moved > 1e-3
                                        and float((ball - plain).abs().mean()) > 1e-3
                                        and backend.describe().get("depth", {}).get("used") is True),
           "depth_change_mean_abs": round(moved, 5)}
    surf = surface.to(backend.device)
    models = SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), surf, surf * 0.1, surf * 0.9)
    models.to(backend.device)
    backend.prepare(surf, "Make it a stained glass artwork", seed=1)
    started = time.perf_counter()
    result = run_psa(backend, models, PSASettings(seed=1, **PSA_STEPS))
    out["psa_seconds"] = round(time.perf_counter() - started, 3)
    out["psa_iterations"] = {"warm_start": result.warm_start_steps, "joint": result.iterations}
    out["psa_ok"] = (tuple(result.target.shape) == (1, 3, 512, 512) and bool(torch.isfinite(result.target).all())
                     and result.iterations >= 1)
    return out


def _real_models(models: str, device: str) -> dict:
    """Each catalogue model in a models folder (--models, or $LAPIG_MODELS_DIR): its state, and where it is
    ready, its figures at 512 px on the device the manager picks (the one-step model: one preview after a
    warm-up; InstructPix2Pix: one stylize with its 10 steps after a warm-up)."""
    import torch

    from ...lapig_addon.services.install.model_download import model_row
    from ...lapig_core.diffusion import catalogue, device_fit, one_step
    from ...lapig_core.diffusion.catalogue import ModelError
    from ...lapig_core.lgst import get_backend

    if not models:
        return {"note": "no --models folder given: real models not looked for"}
    out = {}
    surface = torch.rand(1, 3, 512, 512, generator=torch.Generator().manual_seed(0))
    for entry in catalogue.CATALOGUE:
        row = model_row(entry.key, models)
        figures = {"state": row.state, "line": row.line}
        out[entry.key] = figures
        if row.state != "ready":
            continue
        try:
            plan = device_fit.require_fit(row.folder, device, entry.title)
        except ModelError as exc:
            figures["fits"] = False
            figures["why"] = str(exc)
            continue
        figures.update(device=plan.name, dtype=plan.dtype, needed_mb=plan.needed_mb)
        if torch.cuda.is_available():
            torch.cuda.reset_peak_memory_stats()
        if entry.kind == "img2img":
            run = lambda seed: one_step.preview(row.folder, surface, "a stained glass window", size=512,  # noqa: E731
                                                choice=device, seed=seed)
        elif entry.kind == "depth-adapter":  # InstructPix2Pix with it, on a ball before a wall
            base = model_row("instruct-pix2pix", models)
            if base.state != "ready":
                figures["note"] = "InstructPix2Pix is not ready in that folder: the adapter has no UNet to condition"
                continue
            from .tiny_pipeline import tiny_geometry

            backend = get_backend("instruct-pix2pix", model=base.folder, size=512, device=device,
                                  depth_adapter=row.folder, geometry=tiny_geometry(512, 512, "ball"))
            run = lambda seed: backend.stylize(surface, "Make it a stained glass artwork", seed=seed)  # noqa: E731
        else:
            backend = get_backend("instruct-pix2pix", model=row.folder, size=512, device=device)
            run = lambda seed: backend.stylize(surface, "Make it a stained glass artwork", seed=seed)  # noqa: E731
        run(0)  # the load and the first call
        started = time.perf_counter()
        run(1)
        figures["preview_seconds" if entry.kind == "img2img" else "stylize_seconds_512"] = round(
            time.perf_counter() - started, 3)
        if torch.cuda.is_available() and plan.device == "cuda":
            figures["peak_memory_mb"] = round(torch.cuda.max_memory_allocated() / 2 ** 20, 1)
    return out


def run(args) -> dict:
    from ...lapig_addon.services.install.model_download import runs_half
    from ...lapig_core.diffusion import catalogue
    from .fake_model_hub import FakeModelHub
    from .tiny_pipeline import make_tiny_adapter, make_tiny_pipeline

    device = getattr(args, "device", None) or "auto"
    out_dir = getattr(args, "out", None)
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="lapig-bench-diffusion-", dir=out_dir or None) as work:
        repos = {"tiny/ip2p": make_tiny_pipeline(os.path.join(work, "repo-ip2p"), "ip2p"),
                 "tiny/turbo": make_tiny_pipeline(os.path.join(work, "repo-turbo"), "img2img", fp16_copies=True),
                 "tiny/depth": make_tiny_adapter(os.path.join(work, "repo-depth"))}
        ip2p = replace(catalogue.model("instruct-pix2pix"), repo_id="tiny/ip2p")
        turbo = replace(catalogue.model("sd-turbo"), repo_id="tiny/turbo")
        depth = replace(catalogue.model("depth-adapter"), repo_id="tiny/depth")
        from ...lapig_core.diffusion import fetch

        with FakeModelHub(repos) as hub:
            summary = {"benchmark": "diffusion", "model": "tiny random pipelines (about 0.4 MB each)"}
            summary.update(_checks(hub, work, ip2p))
            half = runs_half(device)  # a GPU: the fp16 copies, as the preferences' Download takes them there
            turbo_folder = fetch.download(turbo, os.path.join(work, "download"), True, hub.url, half=half).folder
            summary["turbo_fp16_copies"] = half
            depth_folder = fetch.download(depth, os.path.join(work, "download"), True, hub.url, half=half).folder
        ip2p_folder = os.path.join(work, "download", ip2p.key)
        summary.update(_runs(ip2p_folder, turbo_folder, device))
        summary.update(_depth_runs(ip2p_folder, depth_folder, device))
    summary["real_models"] = _real_models(getattr(args, "models", "") or os.environ.get("LAPIG_MODELS_DIR", ""),
                                          device)
    return summary
