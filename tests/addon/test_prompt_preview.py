# SPDX-License-Identifier: GPL-3.0-or-later
"""The fast path (issue 53, item 4) without Blender: the preview waits DELAY_S after the last keystroke (a fake
clock), a newer prompt cancels the preview under way and its image is never shown; then a real preview of a
captured surface through a tiny one-step model, compensated and shown by the sink."""
import importlib
import time

import pytest

ADDON = "lapig.lapig_addon"


def _preview_module():
    return importlib.import_module(f"{ADDON}.services.generate.prompt_preview")


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class HeldJob:
    """A job that runs until the test lets it end (release()), as a model call that takes a while."""

    def __init__(self, prompt, made):
        self.request = type("Request", (), {"prompt": prompt})()
        self.state, self.message, self._released = "PENDING", "", False
        made.append(self)

    @property
    def finished(self):
        return self.state in ("DONE", "CANCELLED", "FAILED")

    def step(self):
        if self.state == "PENDING":
            self.state = "RUNNING"
        elif self.state == "RUNNING" and self._released:
            self.state = "DONE"

    def cancel(self):
        self.state = "CANCELLED"

    def release(self):
        self._released = True


def test_the_preview_waits_for_the_typing_to_pause_and_a_newer_prompt_cancels_the_older():
    preview_module = _preview_module()
    clock, made = Clock(), []
    preview = preview_module.PromptPreview(lambda prompt: HeldJob(prompt, made), delay_s=0.5, clock=clock)
    for text in ("a", "a st", "a stained"):  # typing, 0.2 s between keystrokes
        preview.typed(text)
        clock.now += 0.2
        assert preview.tick() and made == []  # no preview while the typing goes on
    clock.now += 0.25  # 0.45 s after the last keystroke
    preview.tick()
    assert made == []
    clock.now += 0.1  # 0.55 s: the last prompt's preview starts, the earlier ones never do
    preview.tick()
    assert [job.request.prompt for job in made] == ["a stained"] and made[0].state == "RUNNING"
    preview.typed("a stained glass")  # a newer prompt while it runs: cancelled, never shown
    assert made[0].state == "CANCELLED" and preview.cancelled == 1
    made[0].release()
    clock.now += 0.3
    preview.tick()
    assert len(made) == 1  # the new one waits its own 0.5 s
    clock.now += 0.3
    preview.tick()
    assert [job.request.prompt for job in made] == ["a stained", "a stained glass"]
    made[1].release()
    preview.tick()
    assert preview.shown == ["a stained glass"] and not preview.busy


def test_generate_stops_the_preview_and_what_waits():
    preview_module = _preview_module()
    clock, made = Clock(), []
    preview = preview_module.PromptPreview(lambda prompt: HeldJob(prompt, made), delay_s=0.5, clock=clock)
    preview.typed("ink")
    clock.now += 1.0
    preview.tick()
    preview.typed("ink wash")
    preview.stop()  # Generate: the full PSA run; no preview may land on its result
    clock.now += 1.0
    preview.tick()
    assert [job.request.prompt for job in made] == ["ink"] and made[0].state == "CANCELLED"
    assert preview.shown == [] and not preview.busy


def test_the_fast_path_only_with_a_ready_one_step_model_and_a_diffusion_look():
    problem = _preview_module().fast_path_problem
    assert problem("one-step", "/models/sd-turbo") == ""
    assert problem("instruct-pix2pix", "/models/sd-turbo") == ""
    assert "not ready" in problem("one-step", "")
    assert "no one-step preview" in problem("styletransfer", "/models/sd-turbo")
    state = importlib.import_module(f"{ADDON}.services.state")
    panel_state = importlib.import_module(f"{ADDON}.services.panel.panel_state")
    request = state.GenerateRequest(prompt="ink", backend="one-step", mix="", psa=True, adaptation=0.5, seed=0,
                                    one_step_model="/models/sd-turbo")
    assert panel_state.fast_path_line(request).startswith("The projector previews the prompt as you type")
    assert panel_state.fast_path_line(state.overridden(request, one_step_model="")) == ""  # not ready: no line


def test_a_preview_of_the_captured_surface_through_the_one_step_model(seams, tmp_path):
    pytest.importorskip("torch")
    pytest.importorskip("diffusers")
    pytest.importorskip("transformers")
    from lapig.tools.bench.tiny_pipeline import make_tiny_pipeline

    capture_job = importlib.import_module(f"{ADDON}.services.capture.capture_job")
    capture_job.CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    model = make_tiny_pipeline(tmp_path / "sd-turbo", "img2img")
    preview_module = _preview_module()
    sink = seams.sinks[0]
    clock = Clock()

    def start(prompt):
        job = preview_module.PromptPreviewJob(seams, preview_module.PreviewRequest(prompt, model, seed=1))
        job.poll_timeout = 0.05
        return job

    preview = preview_module.PromptPreview(start, delay_s=0.5, clock=clock)
    preview.typed("a mosaic")
    clock.now += 0.6
    deadline = time.monotonic() + 120
    while preview.tick() and time.monotonic() < deadline:
        pass
    assert preview.said == "" and preview.shown == ["a mosaic"]
    frame = sink.frames[-1]
    assert frame.summary == {"preview": "a mosaic"} and frame.folder == ""
    w, h = seams.store.projector_model().width, seams.store.projector_model().height
    assert (frame.width, frame.height) == (w, h) and frame.image.ndim == 3 and 0.0 <= frame.image.min()
    assert seams.store.result == ("", "", "")  # no result folder is written
