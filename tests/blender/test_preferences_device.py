"""The add-on preferences' Device (issue 37): Auto or CPU, read through scene_state as the other settings are, and
the CUDA command shown only where an NVIDIA GPU has no torch that can use it."""
import bpy
import pytest

from test_panels import RecordingLayout


def _draw(preferences, models_folder=""):
    log = []
    cls = preferences.LAPIG_AP_preferences
    fake = type("Prefs", (), {"layout": RecordingLayout(log), "device": "AUTO", "ip2p_model": "",
                              "turbo_model": "", "models_folder": models_folder, "hub_endpoint": "",
                              "hub_token": "", "bl_rna": cls.bl_rna})()
    cls.draw(fake, bpy.context)
    return log


@pytest.mark.blender
def test_the_device_preference_and_the_cuda_command(lapig_registered, monkeypatch):
    from lapig.lapig_addon.blender import preferences, scene_state
    from lapig.lapig_core.common.gpu_torch import TorchBuild

    assert set(preferences.LAPIG_AP_preferences.bl_rna.properties["device"].enum_items.keys()) == {"AUTO", "CPU"}
    assert scene_state.compute_device() == "auto"  # the add-on registered, not enabled (the bpy module): Auto
    monkeypatch.setattr(preferences, "installed_torch", lambda: TorchBuild(True, "2.13.0+cpu"))
    monkeypatch.setattr(preferences, "nvidia_gpu_present", lambda: True)
    log = _draw(preferences)
    assert ("prop", "device") in log and ("operator", "lapig.copy_cuda_command") in log
    commands = [entry[1] for entry in log if entry[0] == "label" and "download.pytorch.org/whl/cu" in entry[1]]
    assert len(commands) == 1 and '"torch==2.13.0"' in commands[0] and "--target" in commands[0]
    monkeypatch.setattr(preferences, "nvidia_gpu_present", lambda: False)  # no GPU: nothing to install
    log = _draw(preferences)
    assert ("label", "torch 2.13.0+cpu: CPU only", "CHECKMARK") in log
    assert ("operator", "lapig.copy_cuda_command") not in log


@pytest.mark.blender
def test_the_torch_box_says_what_is_installed_and_offers_the_install_button(lapig_registered, monkeypatch):
    from lapig.lapig_addon.blender import preferences, torch_installer
    from lapig.lapig_addon.services.install import torch_install
    from lapig.lapig_core.common.gpu_torch import TorchBuild

    monkeypatch.setattr(preferences, "installed_torch", lambda: TorchBuild(False))
    monkeypatch.setattr(preferences, "nvidia_gpu_present", lambda: False)
    monkeypatch.setattr(torch_installer, "online_access", lambda: False)
    log = _draw(preferences)
    assert ("label", "torch not installed", "ERROR") in log  # never a check mark beside it
    assert ("prop", "torch_build") in log and ("operator", "lapig.install_torch") in log
    assert ("operator", "lapig.install_torch_wheel") in log
    assert any("Preferences > System > Network" in text for text in _sentences(log))  # why Install is greyed
    assert not any("see the add-on preferences" in text.lower() for text in _sentences(log))  # we are there
    monkeypatch.setattr(torch_installer, "online_access", lambda: True)
    assert not any("Preferences > System > Network" in text for text in _sentences(_draw(preferences)))

    class Running:  # an install under way: its progress and its Cancel instead of the buttons
        finished, progress, message = False, 0.4, "downloading torch-2.13.0+cpu: 40% of 190 MB"

    monkeypatch.setattr(torch_install.SLOT, "job", Running())
    log = _draw(preferences)
    assert ("progress", "downloading torch-2.13.0+cpu: 40% of 190 MB (40%)") in log
    assert ("operator", "lapig.cancel_torch_install") in log and ("operator", "lapig.install_torch") not in log


def _sentences(log):
    from test_panels import sentences

    return sentences(log)


@pytest.mark.blender
def test_the_model_manager_box_shows_each_model_with_its_licence_state_and_buttons(lapig_registered, monkeypatch,
                                                                                  tmp_path):
    from lapig.lapig_addon.blender import model_manager, preferences, torch_installer
    from lapig.lapig_addon.services.install import model_download

    monkeypatch.setattr(torch_installer, "online_access", lambda: False)
    log = _draw(preferences, str(tmp_path))
    text = _sentences(log)
    assert ("prop", "models_folder") in log and ("prop", "hub_token") in log and ("prop", "hub_endpoint") in log
    assert ("label", "InstructPix2Pix (timbrooks/instruct-pix2pix)", "IMPORT") in log
    assert ("label", "SD-Turbo (stabilityai/sd-turbo)", "IMPORT") in log
    assert ("label", "T2I-Adapter depth (SD 1.5) (TencentARC/t2iadapter_depth_sd15v2)", "IMPORT") in log
    assert any(t.startswith("Licence: MIT") for t in text) and any("Stability AI" in t for t in text)
    assert any(t.startswith("Licence: Apache-2.0") for t in text)
    assert any(t.startswith("absent (size: listed when the download starts)") for t in text)
    assert any(t.startswith("absent (size: about 309 MB") for t in text)
    assert log.count(("operator", "lapig.download_model")) == 3 and ("operator", "lapig.use_model_folder") in log
    assert any(t.startswith("Online access is off in Blender") and "Use Folder" in t for t in text)
    from lapig.lapig_core.common.gpu_torch import installed_torch

    where = "Diffusion runs on" if installed_torch().present else "Diffusion needs torch: install it in the torch box"
    assert any(t.startswith(where) for t in text)  # the torch-free tier: the line says what to install
    from lapig.lapig_core.common import gpu_torch

    monkeypatch.setattr(gpu_torch, "nvidia_gpu_present", lambda: True)  # a GPU, and a torch without CUDA
    monkeypatch.setattr(gpu_torch, "installed_torch", lambda: gpu_torch.TorchBuild(True, "2.13.0+cpu"))
    assert model_manager.device_line().startswith("Diffusion would run on the CPU (torch 2.13.0+cpu: CPU only): this "
                                                  "computer has an NVIDIA GPU; install a CUDA build")

    class Running:  # a download under way: its progress bar and Cancel in its row
        finished, progress, message = False, 0.25, "diffusion_pytorch_model.safetensors: 25% of 3438 MB"
        request = model_download.DownloadRequest("sd-turbo", str(tmp_path), True)

    monkeypatch.setattr(model_download.DOWNLOADS, "job", Running())
    log = _draw(preferences, str(tmp_path))
    assert ("progress", "diffusion_pytorch_model.safetensors: 25% of 3438 MB (25%)") in log
    assert ("operator", "lapig.cancel_model_download") in log and log.count(("operator", "lapig.download_model")) == 2


@pytest.mark.blender
def test_download_refuses_offline_and_use_folder_refuses_a_folder_that_is_not_a_pipeline(lapig_registered,
                                                                                         monkeypatch, tmp_path):
    from lapig.lapig_addon.blender import torch_installer

    monkeypatch.setattr(torch_installer, "online_access", lambda: False)
    with pytest.raises(RuntimeError, match="Online access is off in Blender"):
        bpy.ops.lapig.download_model(model="sd-turbo")
    with pytest.raises(RuntimeError, match="unknown model 'dall-e'"):
        monkeypatch.setattr(torch_installer, "online_access", lambda: True)
        bpy.ops.lapig.download_model(model="dall-e")
    with pytest.raises(RuntimeError, match="is not a diffusers pipeline: it has no model_index.json"):
        bpy.ops.lapig.use_model_folder(model="sd-turbo", directory=str(tmp_path))


@pytest.mark.blender
def test_download_in_a_script_runs_to_the_end_and_the_model_is_ready(lapig_registered, monkeypatch,
                                                                               tmp_path):
    """Download from a script (no UI: the job runs in execute()), against the local hub named by HF_ENDPOINT; the
    model manager then finds it ready there."""
    pytest.importorskip("diffusers")
    from dataclasses import replace

    from lapig.lapig_addon.blender import model_manager, torch_installer
    from lapig.lapig_core.diffusion import catalogue
    from lapig.tools.bench.fake_model_hub import FakeModelHub
    from lapig.tools.bench.tiny_pipeline import make_tiny_pipeline

    repo = make_tiny_pipeline(tmp_path / "repo", "ip2p")
    monkeypatch.setattr(catalogue, "CATALOGUE", (replace(catalogue.CATALOGUE[0], repo_id="tiny/ip2p"),)
                        + catalogue.CATALOGUE[1:])
    monkeypatch.setattr(model_manager, "models_root", lambda prefs=None: str(tmp_path / "models"))
    monkeypatch.setattr(torch_installer, "online_access", lambda: True)
    with FakeModelHub({"tiny/ip2p": repo}) as hub:
        monkeypatch.setenv("HF_ENDPOINT", hub.url)
        assert bpy.ops.lapig.download_model(model="instruct-pix2pix") == {"FINISHED"}
    folder = tmp_path / "models" / "instruct-pix2pix"
    assert (folder / "model_index.json").is_file() and (folder / ".lapig-model.json").is_file()
    from lapig.lapig_addon.services.install.model_download import ready_folder

    assert ready_folder("instruct-pix2pix", str(tmp_path / "models")) == str(folder)
