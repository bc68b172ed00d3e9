"""Reliability without Blender: one-line errors, the shared ranges, Ctrl-C in a job, and the refusals of the
bpy-free layers (a damaged checkpoint header, a non-text fingerprint, an export path that is a folder).

The command-line cases that open a .blend are in tests/blender/test_reliability_cli.py.
"""
import importlib
import threading
import time

import numpy as np
import pytest

ADDON = "lapig.lapig_addon"


def _addon(name):
    return importlib.import_module(f"{ADDON}.{name}")  # afresh, with bpy blocked (conftest.py)


@pytest.fixture
def errors():
    return _addon("services.errors")


@pytest.fixture
def limits():
    return _addon("services.limits")


@pytest.fixture
def cli():
    return _addon("cli.main")


def test_one_line_keeps_a_refusal_as_worded_and_names_the_type_of_anything_else(errors):
    assert errors.one_line(ValueError("Type a prompt")) == "Type a prompt"
    assert errors.one_line(KeyError("arch")) == "KeyError: 'arch'"
    assert errors.one_line(RuntimeError('Error: File format is not supported in file "x.blend"\n')) == \
        'File format is not supported in file "x.blend"'  # an operator's error report, through bpy.ops
    assert errors.one_line(RuntimeError("CUDA error:\n  out of memory")) == "RuntimeError: CUDA error: out of memory"
    assert errors.one_line(MemoryError()) == "MemoryError"
    assert len(errors.one_line(ValueError("x" * 5000))) == errors.MAX_CHARS


def test_a_missing_dependency_says_what_is_needed_not_no_module_named(errors):
    said = errors.one_line(ModuleNotFoundError("No module named 'torch'", name="torch"))
    assert said.startswith("LAPIG needs torch: see the add-on preferences")
    assert errors.one_line(ModuleNotFoundError("No module named 'cv2.x'", name="cv2.x")).startswith(
        "LAPIG needs opencv-contrib-python-headless")
    assert errors.one_line(ModuleNotFoundError("No module named 'foo'", name="foo")) == "No module named 'foo'"


def test_a_limit_refuses_values_outside_its_range_and_gives_the_property_bounds(limits):
    size = limits.LIMITS["working_size"]
    assert size.bounds() == {"min": 32, "max": 1024}
    assert size.problem(32) == size.problem(1024) == ""
    assert size.problem(100000) == "Working size must be between 32 and 1024, got 100000"
    assert limits.LIMITS["style_seed"].bounds() == {"min": 0}
    assert limits.LIMITS["style_seed"].problem(-5) == "Style seed must be at least 0, got -5"
    assert limits.first_problem({"train_count": 4, "crossfade_frames": 0}) == \
        "Crossfade frames must be between 2 and 10000, got 0"


def test_export_settings_refuse_a_crossfade_the_panel_would_not_allow(state):
    assert state.ExportSettings(path="/p.png", bit_depth=8, crossfade_frames=60).problem() == ""
    for frames in (0, -5, 100000):
        assert "Crossfade frames must be between 2 and 10000" in \
            state.ExportSettings(path="/p.png", bit_depth=8, crossfade_frames=frames).problem()


@pytest.mark.parametrize("argv, message", [
    (["capture", "--out", "d", "--size", "100000"], "--size: Working size must be between 32 and 1024, got 100000"),
    (["capture", "--out", "d", "--train", "0"], "--train: Training images must be between 1 and 2000, got 0"),
    (["capture", "--out", "d", "--samples", "0"], "--samples: Samples must be between 1 and 64, got 0"),
    (["stylize", "--prompt", "x", "--seed", "-5"], "--seed: Style seed must be at least 0, got -5"),
    (["stylize", "--prompt", "x", "--adaptation", "1.5"],
     "--adaptation: Adaptation must be between 0.0 and 1.0, got 1.5"),
    (["train", "--iterations", "-5"], "--iterations: Fine-tuning iterations must be between 0 and 100000, got -5"),
    (["export", "--out", "p.png", "--frames", "0"], "--frames: Crossfade frames must be between 2 and 10000, got 0"),
    (["export", "--out", "p.png", "--frames", "-5"], "--frames: Crossfade frames must be between 2 and 10000"),
    (["export", "--out", "p.png", "--frames", "100000"], "--frames: Crossfade frames must be between 2 and 10000"),
])
def test_the_command_line_refuses_out_of_range_options_before_anything_opens(cli, capsys, tmp_path, monkeypatch,
                                                                               argv, message):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 1  # bpy is blocked here: the check comes before any Blender work
    err = capsys.readouterr().err
    assert err.startswith(f"error: {message}") and err.count("\n") == 1  # one line
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_debug_shows_the_traceback(cli, capsys):
    assert cli.main(["--debug", "capture", "--out", "d", "--size", "0"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and err.endswith("error: --size: Working size must be between 32 and 1024, got 0\n")
    assert cli.main(["capture", "--out", "d", "--size", "0", "--debug"]) == 1  # after the command name too
    assert "Traceback" in capsys.readouterr().err


def test_ctrl_c_in_a_worker_job_stops_and_joins_the_worker(monkeypatch):
    jobs = _addon("services.jobs")
    seen = {}

    class Spinning(jobs.WorkerJob):
        def work(self, inputs, report, cancel_event):
            while not cancel_event.is_set():  # as the training and PSA loops do between iterations
                report(0.5, "working")
                time.sleep(0.01)
            time.sleep(0.2)  # still busy for a moment after the cancel
            seen["worker_saw_cancel"] = True

    messages = []

    def ctrl_c(progress, message):
        messages.append(message)
        if message == "working":
            raise KeyboardInterrupt

    job = Spinning()
    with pytest.raises(KeyboardInterrupt):
        job.run(on_progress=ctrl_c)
    assert seen == {"worker_saw_cancel": True}  # joined: nothing of it runs when Python exits
    assert not any(t.name == job.title for t in threading.enumerate())
    assert job.state == "CANCELLED" and messages[-1] == "interrupted: stopping"


def _tiny_set(root, fingerprint):
    from lapig.lapig_core.capture.dataset import DatasetLayout, write_capture, write_projector_images, write_setup_json

    layout = DatasetLayout(root, "wall")
    images = [np.full((8, 8, 3), v, np.float32) for v in (0.0, 1.0, 0.5)]
    write_projector_images(layout, "ref", images)
    write_projector_images(layout, "train", images[:2])
    for kind, group in (("ref", images), ("train", images[:2])):
        for index, image in enumerate(group, start=1):
            write_capture(layout, "warp", kind, index, image)
    write_setup_json(layout, {"gray_level": 0.5, "fingerprint": fingerprint})
    return layout


def test_a_non_text_fingerprint_is_refused_when_the_set_is_loaded(tmp_path):
    from lapig.lapig_core.capture.dataset import DatasetError, load_capture_set

    assert load_capture_set(_tiny_set(tmp_path / "good", "90d1dc1c").setup_dir).meta["fingerprint"] == "90d1dc1c"
    with pytest.raises(DatasetError, match='"fingerprint" must be text, got 12345'):
        load_capture_set(_tiny_set(tmp_path / "bad", 12345).setup_dir)


@pytest.mark.parametrize("damage, message", [
    (lambda header: header.pop("arch"), "damaged header: 'arch' is missing"),
    (lambda header: header.update(working_size="big"), "damaged header: 'working_size' is 'big', not int"),
    (lambda header: header.update(arch="ResNet"), "unknown architecture 'ResNet'"),
])
@pytest.mark.torch
def test_a_checkpoint_with_a_damaged_header_is_refused_with_its_name(tmp_path, damage, message):
    import torch

    from lapig.lapig_core.photometric import checkpoints

    data = torch.load(checkpoints.pretrained_path("PCNet", "simulation"), map_location="cpu", weights_only=True)
    damage(data["header"])
    path = tmp_path / "pcnet.pt"
    torch.save(data, path)
    with pytest.raises(checkpoints.CheckpointError, match=message) as refused:
        checkpoints.load_checkpoint(path)
    assert str(refused.value).startswith("pcnet.pt ")
    path.write_bytes(b"not a checkpoint at all")
    with pytest.raises(checkpoints.CheckpointError, match=r"pcnet.pt is not a readable checkpoint \(\w+"):
        checkpoints.load_checkpoint(path)


def test_export_into_an_existing_folder_is_refused_and_writes_nothing_beside_it(tmp_path):
    from lapig.lapig_core.export.projector_image import ExportError, crossfade_sequence, export_projector_image

    folder = tmp_path / "exports"
    folder.mkdir()
    working = np.full((9, 12, 3), 0.5, np.float32)  # the projector's 4:3 aspect
    with pytest.raises(ExportError, match="output path is a folder"):
        export_projector_image(folder, working, 16, 12)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exports"] and not any(folder.iterdir())
    progress = []
    frames = crossfade_sequence(tmp_path / "fade", working, working, frames=3, width=16, height=12,
                                on_progress=lambda p, m: progress.append(m))
    assert len(frames) == 3 and progress[-1] == "wrote crossfade frame 3/3"


def test_stylize_takes_the_output_size_and_what_happens_outside_the_object(cli):
    parser = cli._parser()
    args = parser.parse_args(["stylize", "--prompt", "x", "--output-size", "640", "--light-outside"])
    assert (args.output_size, args.dark_outside) == (640, False)
    args = parser.parse_args(["stylize", "--prompt", "x"])
    assert (args.output_size, args.dark_outside) == (None, None)  # the scene's values stay
    assert parser.parse_args(["stylize", "--prompt", "x", "--dark-outside"]).dark_outside is True
    with pytest.raises(ValueError, match="--output-size: Output size must be between 0 and 8192"):
        cli.check_ranges(parser.parse_args(["stylize", "--prompt", "x", "--output-size", "9000"]))
    state = _addon("services.state")
    scene_request = state.GenerateRequest("x", "styletransfer", "", True, 0.5, 0)
    request = state.overridden(scene_request, output_size=640, dark_outside=False)
    assert (request.output_size, request.dark_outside) == (640, False)
