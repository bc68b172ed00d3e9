"""The add-on preferences' Device (issue 37): Auto or CPU, read through scene_state as the other settings are, and
the CUDA command shown only where an NVIDIA GPU has no torch that can use it."""
import bpy
import pytest

from test_panels import RecordingLayout


def _draw(preferences):
    log = []
    cls = preferences.LAPIG_AP_preferences
    fake = type("Prefs", (), {"layout": RecordingLayout(log), "device": "AUTO", "ip2p_model": "",
                              "bl_rna": cls.bl_rna})()
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
    from lapig.lapig_addon.services import torch_install
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
