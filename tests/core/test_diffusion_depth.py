# SPDX-License-Identifier: GPL-3.0-or-later
"""Depth conditioning (issue 53, item 3): a tiny InstructPix2Pix pipeline and a tiny depth adapter (random weights,
made here) served by the local fake hub, downloaded by the model manager, then looks whose drawing follows the
object's depth: the same seed gives the same image for the same depth and another image for another depth."""
from __future__ import annotations

import os
from dataclasses import replace

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("diffusers")
pytest.importorskip("transformers")

from lapig.lapig_core.diffusion import catalogue, depth_condition, fetch, pipeline_folder as pf
from lapig.lapig_core.diffusion.catalogue import ModelError
from lapig.lapig_core.lgst import get_backend
from lapig.tools.bench.fake_model_hub import FakeModelHub
from lapig.tools.bench.tiny_pipeline import make_tiny_adapter, make_tiny_pipeline, tiny_geometry

PROMPT = "Make it a stained glass artwork"


@pytest.fixture(scope="module")
def downloaded(tmp_path_factory):
    """{'ip2p': folder, 'depth': folder}: both downloaded by the manager from the fake hub."""
    work = tmp_path_factory.mktemp("depth")
    repos = {"tiny/ip2p": make_tiny_pipeline(work / "repo-ip2p", "ip2p"),
             "tiny/depth": make_tiny_adapter(work / "repo-depth")}
    ip2p = replace(catalogue.model("instruct-pix2pix"), repo_id="tiny/ip2p")
    depth = replace(catalogue.model("depth-adapter"), repo_id="tiny/depth")
    root = str(work / "models")
    with FakeModelHub(repos) as hub:
        seen = []
        out = {"ip2p": fetch.download(ip2p, root, True, hub.url).folder,
               "depth": fetch.download(depth, root, True, hub.url, report=lambda f, m: seen.append(m)).folder}
    out["root"], out["lines"] = root, seen
    return out


def test_the_depth_adapter_is_in_the_catalogue_with_its_licence_and_downloads_as_one_model(downloaded):
    entry = catalogue.model("depth-adapter")
    assert entry.repo_id == "TencentARC/t2iadapter_depth_sd15v2" and entry.licence.startswith("Apache-2.0")
    assert entry.layout == catalogue.MODEL and "309 MB" in entry.size_hint
    folder = downloaded["depth"]
    assert sorted(os.listdir(folder)) == [".lapig-model.json", "config.json", "diffusion_pytorch_model.bin"]
    assert pf.folder_state(folder, layout=catalogue.MODEL).state == pf.READY and pf.verify(folder) == []
    assert any("checking the model" in line for line in downloaded["lines"])
    from lapig.lapig_addon.services.install.model_download import model_row, use_folder

    row = model_row("depth-adapter", downloaded["root"])
    assert row.state == "ready" and row.folder == folder
    assert use_folder("depth-adapter", folder) == folder
    assert model_row("depth-adapter", os.path.join(downloaded["root"], "nothing")).line.endswith(
        "(size: about 309 MB (one weights file))")


def test_a_folder_that_is_not_an_adapter_is_one_line(downloaded, tmp_path):
    from lapig.lapig_addon.services.install.model_download import use_folder

    with pytest.raises(ModelError, match=r"is not a T2IAdapter: it has no config\.json"):
        use_folder("depth-adapter", str(tmp_path))
    with pytest.raises(ModelError, match=r"holds a StableDiffusionInstructPix2PixPipeline|no config\.json"):
        use_folder("depth-adapter", downloaded["ip2p"])
    os.makedirs(tmp_path / "unet")
    (tmp_path / "unet" / "config.json").write_text('{"_class_name": "UNet2DConditionModel"}')
    with pytest.raises(ModelError, match="holds a UNet2DConditionModel, not a T2IAdapter"):
        use_folder("depth-adapter", str(tmp_path / "unet"))
    with pytest.raises(ModelError, match=r"unknown model 'depth': the add-on supports .*depth-adapter"):
        catalogue.model("depth")


def test_a_refused_token_and_a_pipeline_repository_for_the_adapter_are_one_line_each(downloaded, tmp_path):
    adapter_repo = make_tiny_adapter(tmp_path / "repo-depth")
    entry = replace(catalogue.model("depth-adapter"), repo_id="tiny/depth")
    with FakeModelHub({"tiny/depth": adapter_repo, "tiny/ip2p": downloaded["ip2p"]}, token="right") as hub:
        with pytest.raises(ModelError, match=r"^the hub refused the token for 'tiny/depth' \(HTTP 401\): check the "
                                             r"Hub token"):
            fetch.download(entry, str(tmp_path / "m"), True, hub.url, token="wrong")
        with pytest.raises(ModelError, match=r"^'tiny/ip2p' is not a diffusers model: it has no config\.json$"):
            fetch.download(replace(entry, repo_id="tiny/ip2p"), str(tmp_path / "m"), True, hub.url, token="right")
        assert not os.path.exists(tmp_path / "m" / "depth-adapter")  # nothing that looks ready
        done = fetch.download(entry, str(tmp_path / "m"), True, hub.url, token="right")
        assert pf.folder_state(done.folder, layout=catalogue.MODEL).state == pf.READY


def test_the_one_step_look_without_its_model_is_one_line(tmp_path):
    from lapig.lapig_core.lgst import LGSTUnavailable

    backend = get_backend("one-step", model=str(tmp_path), device="cpu")
    assert backend.availability(model=str(tmp_path))[1].startswith(f"no one-step model at {tmp_path}")
    with pytest.raises(LGSTUnavailable, match="download it in the add-on preferences"):
        backend.prepare(torch.rand(1, 3, 16, 16), PROMPT)
    assert get_backend("one-step").availability()[1].startswith("the one-step look needs the one-step model")


def test_the_depth_image_is_near_bright_far_dark_and_none_without_a_3d_model():
    from lapig.lapig_core.lgst.world.geometry import from_capture

    image = depth_condition.depth_image(tiny_geometry(48, 64, "ball"), 48, 64)
    assert image.shape == (1, 3, 48, 64)
    assert float(image[0, 0, 24, 32]) == pytest.approx(1.0)  # the ball's front, nearest
    assert float(image[0, 0, 2, 2]) == pytest.approx(depth_condition.NEAR_FLOOR)  # the wall behind it
    slope = depth_condition.depth_image(tiny_geometry(48, 64, "slope"), 48, 64)[0, 0]
    assert float(slope[24, 1]) > float(slope[24, 32]) > float(slope[24, 62])  # leaning away to the right
    assert depth_condition.depth_image(from_capture(torch.rand(48, 64, 3).numpy()), 48, 64) is None
    assert depth_condition.depth_image("capture", 48, 64) is None and depth_condition.depth_image(None, 8, 8) is None


def _look(downloaded, geometry, adapter=True, seed=3, path="stylize"):
    backend = get_backend("instruct-pix2pix", model=downloaded["ip2p"], size=64, steps=2, psa_steps=1, device="cpu",
                          depth_adapter=downloaded["depth"] if adapter else None, geometry=geometry)
    surface = torch.rand(1, 3, 48, 64, generator=torch.Generator().manual_seed(0))
    if path == "stylize":
        return backend.stylize(surface, PROMPT, seed=seed), backend
    backend.prepare(surface, PROMPT, seed=seed)
    with torch.no_grad():
        return backend.forward(), backend


@pytest.mark.parametrize("path", ["stylize", "forward"])
def test_the_drawing_changes_with_the_depth_and_only_with_it(downloaded, path):
    ball, slope = tiny_geometry(48, 64, "ball"), tiny_geometry(48, 64, "slope")
    a, backend = _look(downloaded, ball, path=path)
    again, _ = _look(downloaded, ball, path=path)
    other, _ = _look(downloaded, slope, path=path)
    plain, _ = _look(downloaded, ball, adapter=False, path=path)
    assert torch.equal(a, again)  # same depth, same seed: the same image
    assert float((a - other).abs().mean()) > 1e-3  # another depth: another drawing
    assert float((a - plain).abs().mean()) > 1e-3  # the adapter is used at all
    depth = backend.describe()["depth"]
    assert depth["used"] and depth["adapter"] == downloaded["depth"] and 0 < depth["on_object"] <= 1


def test_without_a_3d_model_the_look_says_the_depth_is_not_followed(downloaded):
    look, backend = _look(downloaded, "capture")
    plain, _ = _look(downloaded, None, adapter=False)
    assert torch.equal(look, plain)
    assert backend.describe()["depth"] == {"adapter": downloaded["depth"], "used": False}
    assert depth_condition.NO_DEPTH in backend.describe()["notes"]


def test_an_adapter_for_another_unet_is_refused_in_one_line(downloaded, tmp_path):
    from diffusers import T2IAdapter

    T2IAdapter(in_channels=3, channels=[8, 32], num_res_blocks=1, downscale_factor=8).save_pretrained(str(tmp_path))
    backend = get_backend("instruct-pix2pix", model=downloaded["ip2p"], size=64, steps=2, device="cpu",
                          depth_adapter=str(tmp_path), geometry=tiny_geometry(48, 64))
    with pytest.raises(ModelError, match=r"the depth adapter is for a UNet with blocks \[8, 32\], the "
                                         r"InstructPix2Pix model has \[8, 16\]"):
        backend.prepare(torch.rand(1, 3, 48, 64), PROMPT)


def test_a_stylize_with_depth_runs_psa_end_to_end_and_follows_the_depth(downloaded, tmp_path):
    """pipeline.stylize on a fake-device capture: the depth-conditioned InstructPix2Pix look, PSA on it, the
    projector image; another depth gives another look with the same seed."""
    from lapig.lapig_core.capture.dataset import load_capture_set
    from lapig.lapig_core.capture.fake_device import FakeDevice
    from lapig.lapig_core.capture.sequence import run_capture
    from lapig.lapig_core.capture.settings import CaptureSettings
    from lapig.lapig_core.common.steps import run_to_end
    from lapig.lapig_core.photometric.checkpoints import new_model
    from lapig.lapig_core.photometric.surface_models import SurfaceModels
    from lapig.lapig_core.photometric.training_data import SurfaceTensors
    from lapig.lapig_core.pipeline import stylize
    from lapig.lapig_core.psa.adaptation import PSASettings

    device = FakeDevice(projector_size=(64, 48), camera_size=(96, 72))
    settings = CaptureSettings(out_dir=str(tmp_path / "capture"), train_count=4, test_count=0, working_size=64,
                               chunk=4)
    cs = load_capture_set(run_to_end(run_capture(device, settings))["setup_dir"])
    surf = SurfaceTensors.from_capture_set(cs)
    models = SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), surf.s, surf.i_min, surf.i_max)
    options = {"model": downloaded["ip2p"], "depth_adapter": downloaded["depth"], "size": 64, "steps": 2,
               "psa_steps": 1}
    psa = PSASettings(max_iterations=2, warm_start_steps=2)
    runs = {shape: stylize(cs, models, PROMPT, backend="instruct-pix2pix", backend_options=dict(options),
                           geometry=tiny_geometry(48, 64, shape), settings=psa, seed=1)
            for shape in ("ball", "slope")}
    ball = runs["ball"]
    assert ball.describe["depth"]["used"] and ball.with_psa is not None and ball.with_psa.iterations >= 1
    assert ball.with_psa.projector_image.shape == (1, 3, 48, 64)
    assert float((ball.without.target - runs["slope"].without.target).abs().mean()) > 1e-3
