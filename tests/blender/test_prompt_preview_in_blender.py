# SPDX-License-Identifier: GPL-3.0-or-later
"""The fast path's Blender side (issue 53, item 4): the prompt property's update hands each change to
services/generate/prompt_preview and registers the timer, only where the one-step model is ready and the look is a diffusion
one; Generate stops it. (The debounce and the preview itself: tests/addon/test_prompt_preview.py; this tier may
have no torch, so the backend stays the default one and the look's check is stood in for.)"""
import bpy
import pytest


@pytest.mark.blender
def test_typing_a_prompt_previews_only_with_the_one_step_model_ready(lapig_registered, monkeypatch):
    from lapig.lapig_addon.blender import preferences, prompt_preview

    made, asked = [], []
    monkeypatch.setattr(prompt_preview, "_in_ui", lambda: True)  # the bpy module runs in background mode
    monkeypatch.setattr(prompt_preview, "_start_job", lambda prompt: made.append(prompt))
    s = bpy.context.scene.lapig
    try:
        monkeypatch.setattr(preferences, "ready_model", lambda key: asked.append(key) or "")
        s.prompt = "a mosaic"  # no one-step model ready: nothing changes
        assert asked == ["sd-turbo"] and prompt_preview._session.get("preview") is None
        monkeypatch.setattr(preferences, "ready_model", lambda key: "/models/sd-turbo" if key == "sd-turbo" else "")
        s.prompt = "a mosaic of tiles"  # ready, but the 'styletransfer' look has no one-step preview
        assert prompt_preview._session.get("preview") is None
        real_problem = prompt_preview.fast_path_problem
        monkeypatch.setattr(prompt_preview, "fast_path_problem",
                            lambda backend, model: real_problem("one-step", model))  # as if 'one-step' were chosen
        s.prompt = "a mosaic of glass"
        preview = prompt_preview._session["preview"]
        assert preview.debounce.pending == "a mosaic of glass" and bpy.app.timers.is_registered(prompt_preview._tick)
        prompt_preview.stop()  # what Generate does first
        assert preview.debounce.pending is None and made == []
    finally:
        prompt_preview.unregister()
