"""A world look's sliders (services/generate/look_edit): a change re-makes the scene's result from its record, with no
capture, no Train, no prompt model and no PSA; result.json keeps the values, so a later Generate of the same
prompt and a show's rebuild use them; a bad value or a look without sliders is one line. bpy blocked; the fake
rig of job_fakes."""
import importlib
import json
import os

import numpy as np
import pytest

ADDON = "lapig.lapig_addon"
pytestmark = pytest.mark.torch


def _module(name):
    return importlib.import_module(f"{ADDON}.services.{name}")


def _summary(folder):
    return json.loads(open(os.path.join(folder, "result.json")).read())


def _image(folder, name):
    from lapig.lapig_core.export.result_files import read_result_image

    return read_result_image(folder, name)


@pytest.fixture
def generated(seams):
    _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    request = seams.store.generate_request(prompt="old cobblestones", psa=True)
    out = _module("generate.generate_job").GenerateJob(seams, request, 2).run_to_completion()
    return out["folder"]


def test_a_slider_remakes_the_look_without_prompt_model_training_or_psa(seams, generated, monkeypatch):
    from lapig.lapig_core.lgst import prompt_plan
    from lapig.lapig_core.psa import adaptation

    look_edit, generate_job = _module("generate.look_edit"), _module("generate.generate_job")
    before = _summary(generated)
    assert before["lgst"]["look_parameters"]["scale"] == 1.0 and before["lgst"]["look_record"]["world"]["base"]
    target, projector = _image(generated, "target"), _image(generated, "projector")
    frames = len(seams.sinks[0].frames)

    def never(*a, **k):
        raise AssertionError("the edit ran the prompt model, Train or PSA")
    for module, name in ((prompt_plan, "plan_prompt"), (_module("train.train_job"), "train_models"), (adaptation, "run_psa")):
        monkeypatch.setattr(module, name, never)
    out = look_edit.EditLookJob(seams, {"scale": 2.5, "hue": 40}).run_to_completion()
    assert out["folder"] == generated  # updated in place: Export and the show read the edited look
    after = _summary(generated)
    assert after["lgst"]["look_parameters"]["scale"] == 2.5 and after["lgst"]["look_parameters"]["hue"] == 40
    assert np.abs(_image(generated, "target") - target).mean() > 0.01
    assert np.abs(_image(generated, "projector") - projector).mean() > 0.005
    assert "(edited: Scale 1 -> 2.5, Hue 0 -> 40)" in seams.store.result[1]
    assert seams.store.result[0] == generated and len(seams.sinks[0].frames) == frames + 1
    assert after["metrics"]["simulated_psnr"] > 10
    # a second edit says what differs from the look before it, the figure once
    look_edit.EditLookJob(seams, {"density": 0.3}).run_to_completion()
    line = seams.store.result[1]
    assert line.count("(edited:") == 1 and "Density 0 -> 0.3" in line and line.count(" dB") == 1


def test_the_edited_values_carry_into_a_later_generate_and_a_show(seams, generated):
    from lapig.lapig_core.show.look_state import read_result_record

    look_edit, generate_job = _module("generate.look_edit"), _module("generate.generate_job")
    look_edit.EditLookJob(seams, {"scale": 0.5, "seed": 7}).run_to_completion()
    assert read_result_record(generated)["look_parameters"]["scale"] == 0.5  # the show's rebuild reads them
    same = seams.store.generate_request(prompt="old cobblestones", psa=False)
    again = generate_job.GenerateJob(seams, same, 2).run_to_completion()
    kept = _summary(again["folder"])["lgst"]["look_parameters"]
    assert kept["scale"] == 0.5 and kept["seed"] == 7
    other = generate_job.GenerateJob(seams, seams.store.generate_request(prompt="granite", psa=False), 2)
    fresh = _summary(other.run_to_completion()["folder"])["lgst"]["look_parameters"]
    assert fresh["scale"] == 1.0 and fresh["seed"] == 0  # a new prompt: the plan's values
    # Reset: the plan's values again
    look_edit.EditLookJob(seams, {"hue": 10}).run_to_completion()
    look_edit.EditLookJob(seams, reset=True).run_to_completion()
    assert _summary(seams.store.result[0])["lgst"]["look_parameters"]["hue"] == 0.0


def test_a_bad_value_or_a_look_without_sliders_is_one_line_and_changes_nothing(seams, generated):
    look_edit, pipeline_errors = _module("generate.look_edit"), _module("pipeline_errors")
    before = open(os.path.join(generated, "result.json")).read()
    with pytest.raises(pipeline_errors.PipelineError) as exc:
        look_edit.EditLookJob(seams, {"scale": 40}).run_to_completion()
    assert str(exc.value) == "Scale must be between 0.2 and 5, got 40"
    assert open(os.path.join(generated, "result.json")).read() == before
    styled = _module("generate.generate_job").GenerateJob(seams, seams.store.generate_request(mix="charcoal_wash:1",
                                                                                      psa=False), 2)
    styled.run_to_completion()
    with pytest.raises(pipeline_errors.PipelineError, match="the result's look has no sliders"):
        look_edit.EditLookJob(seams, {"scale": 2}).run_to_completion()


def test_a_show_with_a_moving_world_look_exports_frame_by_frame(seams, generated, tmp_path):
    from lapig.lapig_core.optics.projector_model import ProjectorModel

    show_plan, show_source, show_jobs = _module("show.show_plan"), _module("show.show_source"), _module("show.show_jobs")
    _module("generate.look_edit").EditLookJob(seams, {"speed": 2.0}).run_to_completion()
    plan = show_plan.ShowPlan(looks=(show_plan.ShowLook(result_dir=generated, hold_s=0.4, motion="world",
                                                        motion_period_s=2.0),), fps=10.0)
    assert plan.problem() == ""
    size = (64, 48)  # the fake rig's projector
    source = show_source.ShowSource(plan, projectors=(ProjectorModel(width=size[0], height=size[1], gamma=2.2),),
                                    capture_dir=seams.store.capture_dir)
    assert show_source.uses_producer(source)
    out = show_jobs.ShowExportJob(source, str(tmp_path / "export"), "png").run_to_completion()
    assert out["frames"] == 4
    from lapig.lapig_core.common.imageio import read_image

    folder = tmp_path / "export" / "show"
    frames = [read_image(folder / n) for n in sorted(os.listdir(folder)) if n.endswith(".png")]
    assert len(frames) == 4 and frames[0].shape == (size[1], size[0], 3)
    steps = [float(np.abs(a.astype(np.float32) - b.astype(np.float32)).mean()) for a, b in zip(frames, frames[1:])]
    assert all(s > 1e-4 for s in steps), steps  # it moves every frame
