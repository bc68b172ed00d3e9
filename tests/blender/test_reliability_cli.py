"""Reliability of the command line and of the operators' error boundary (issue 11, items 4 to 6).

Every refusal is one line (`error: ...`, exit status 1) that comes before the expensive step, nothing is
written where the user did not point, no result is left that the scene does not refer to, and Ctrl-C
during torch work ends with exit status 130. Most commands run in this process (cli.main, as
`python -m lapig_addon` calls it); the entry point itself and Ctrl-C run as real processes.
"""
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import pytest
from rig_fixtures import small_rig

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.blender

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MIX = ["--prompt", "x", "--mix", "charcoal_wash:1"]  # an explicit style: no text model to load


def _as_from_a_terminal():
    """In the child: Ctrl-C as a terminal delivers it. A test run started in the background of a script
    (`cmd &`) inherits SIGINT ignored, and Python then never raises KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@dataclass
class Project:
    """A saved .blend with a small capture, fine-tuned models and one saved result."""
    folder: Path
    blend: str
    setup: Path
    results: Path
    result: str  # the result the .blend holds

    @property
    def models(self) -> Path:
        return self.setup / "models"


def _main(*argv) -> int:
    from lapig.lapig_addon.cli import main as cli

    return cli.main([str(a) for a in argv])


def _run(capfd, *argv):
    status = _main(*argv)
    out, err = capfd.readouterr()
    return status, out, err


def _snapshot(folder) -> dict:
    """Every file under `folder` with a digest of its bytes: what 'nothing changed on disk' compares."""
    return {str(p.relative_to(folder)): hashlib.md5(p.read_bytes()).hexdigest()
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}


def _refused(status, err, message):
    """One `error:` line with the message, exit status 1, no traceback."""
    assert status == 1, err[-2000:]
    errors = [line for line in err.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and message in errors[0], err[-2000:]
    assert "Traceback" not in err
    return errors[0]


@pytest.fixture(scope="module")
def project(lapig_registered, tmp_path_factory):
    pytest.importorskip("torch")  # it trains and stylizes; the version matrix's torch-free tier skips its users
    folder = tmp_path_factory.mktemp("project")
    scene = small_rig(folder)[0]
    s = scene.lapig
    s.train_count, s.test_count, s.working_size, s.finetune_iterations = 4, 0, 32, 2
    blend = str(folder / "wall.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    assert _main("train", "--blend", blend, "--save") == 0
    assert _main("stylize", "--blend", blend, *MIX, "--no-psa", "--save") == 0
    from lapig.lapig_addon.blender import scene_state

    state = scene_state.read(bpy.context.scene)  # folders are stored relative to the .blend
    return Project(folder, blend, Path(state.capture_dir), folder / "wall_lapig" / "results", state.result_dir)


@pytest.fixture
def unchanged(project):
    """The project exactly as it was before the test, checked after it."""
    before = _snapshot(project.folder)
    yield
    assert _snapshot(project.folder) == before


@pytest.fixture
def new_results(project):
    """Results a test makes without --save: the test checks them, then they go (the export tests expect
    the .blend's result to be the newest)."""
    before = set(os.listdir(project.results))
    yield lambda: [str(project.results / n) for n in sorted(set(os.listdir(project.results)) - before)]
    for name in set(os.listdir(project.results)) - before:
        shutil.rmtree(project.results / name)


# -- broken files -------------------------------------------------------------------------------------


@pytest.mark.parametrize("content", [b"", os.urandom(4096)], ids=["empty", "corrupt"])
@pytest.mark.parametrize("command", [["capture", "--out", "{dir}/data"],
                                     pytest.param(["train"], marks=pytest.mark.torch),
                                     pytest.param(["stylize", *MIX], marks=pytest.mark.torch),
                                     ["export", "--out", "{dir}/p.png"]])
def test_an_empty_or_corrupt_blend_is_one_line_for_every_command(capfd, tmp_path, content, command):
    blend = tmp_path / "broken.blend"
    blend.write_bytes(content)
    args = [a.format(dir=tmp_path) for a in command]
    status, _, err = _run(capfd, *args, "--blend", blend)
    _refused(status, err, f"cannot open {blend}: it is empty, damaged or not a .blend file")
    assert os.listdir(tmp_path) == ["broken.blend"]


def test_the_entry_point_refuses_a_broken_blend_in_one_line(tmp_path):
    blend = tmp_path / "empty.blend"
    blend.write_bytes(b"")
    # export: the command every release's tier can run (train says first that torch is missing, where it is)
    proc = subprocess.run([sys.executable, "-m", "lapig_addon", "export", "--blend", str(blend), "--out",
                           str(tmp_path / "p.png")], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1 and proc.stderr.strip().splitlines() == [
        f"error: cannot open {blend}: it is empty, damaged or not a .blend file (File format is not supported "
        f"in file \"{blend}\")"]


def test_a_non_text_fingerprint_is_refused_before_training(capfd, project, unchanged):
    setup_json = project.setup / "setup.json"
    original = setup_json.read_bytes()
    setup_json.write_text(json.dumps({**json.loads(original), "fingerprint": 12345}))
    try:
        status, out, err = _run(capfd, "train", "--blend", project.blend)
    finally:
        setup_json.write_bytes(original)
    _refused(status, err, '"fingerprint" must be text, got 12345')
    assert "iteration" not in out  # refused when the set is loaded, not after the training


@pytest.mark.parametrize("damage, said", [
    ("header", "pcnet.pt has a damaged header: 'arch' is missing"),
    ("bytes", "pcnet.pt is not a readable checkpoint"),
])
def test_a_damaged_fine_tuned_checkpoint_is_retrained_and_said(capfd, project, new_results, damage, said):
    import torch

    from lapig.lapig_core.photometric.checkpoints import load_checkpoint

    path = project.models / "pcnet.pt"
    if damage == "header":
        data = torch.load(path, weights_only=True)
        del data["header"]["arch"]
        torch.save(data, path)
    else:
        path.write_bytes(b"\0" * 4096)
    status, _, err = _run(capfd, "stylize", "--blend", project.blend, *MIX, "--no-psa")
    assert status == 0, err[-2000:]
    assert f"note: the saved models could not be used ({said}" in err
    assert "fine-tuned them again and saved over them" in err
    assert load_checkpoint(path, arch="PCNet")[1]["arch"] == "PCNet"  # a good file again
    assert len(new_results()) == 1


# -- wrong numbers and names --------------------------------------------------------------------------


@pytest.mark.parametrize("argv, message", [
    (["capture", "--out", "{dir}/data", "--size", "100000"], "--size: Working size must be between 32 and 1024"),
    (["capture", "--out", "{dir}/data", "--train", "0"], "--train: Training images must be between 1 and 2000"),
    (["stylize", *MIX, "--seed", "-5"], "--seed: Style seed must be at least 0, got -5"),
    (["stylize", *MIX, "--adaptation", "1.5"], "--adaptation: Adaptation must be between 0.0 and 1.0, got 1.5"),
    (["stylize", "--prompt", "stained glass", "--backend", "nope"], "unknown LGST backend 'nope'"),
    (["export", "--out", "{dir}/p.png", "--crossfade", "{dir}/fade", "--frames", "0"],
     "--frames: Crossfade frames must be between 2 and 10000, got 0"),
    (["export", "--out", "{dir}/p.png", "--crossfade", "{dir}/fade", "--frames", "-5"], "got -5"),
    (["export", "--out", "{dir}/p.png", "--crossfade", "{dir}/fade", "--frames", "100000"], "got 100000"),
    (["export", "--out", "{dir}"], "output path is a folder"),  # not {dir}.png beside it
])
def test_wrong_values_are_refused_before_any_work(capfd, project, unchanged, tmp_path, argv, message):
    args = [a.format(dir=tmp_path / "out") for a in argv]
    (tmp_path / "out").mkdir()
    status, out, err = _run(capfd, *args, "--blend", project.blend)
    _refused(status, err, message)
    assert "loading the models" not in out
    assert sorted(os.listdir(tmp_path)) == ["out"] and os.listdir(tmp_path / "out") == []


def test_a_capture_too_large_is_refused_before_allocating_from_any_caller(project, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_addon.services.capture.capture_job import CaptureError

    bpy.ops.wm.open_mainfile(filepath=project.blend)
    scene = bpy.context.scene
    settings = scene_state.capture_settings(scene, out_dir=str(tmp_path / "data"), working_size=100000)
    with pytest.raises(CaptureError, match="Working size must be between 32 and 1024, got 100000"):
        headless.run_capture(scene, settings)  # a script, a benchmark: the job checks too
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("what", ["projector", "camera"])
def test_a_deleted_projector_or_camera_is_refused_before_stylizing(capfd, project, unchanged, tmp_path, what):
    bpy.ops.wm.open_mainfile(filepath=project.blend)
    bpy.data.objects.remove(getattr(bpy.context.scene.lapig, what))
    broken = str(tmp_path / "deleted.blend")
    bpy.ops.wm.save_as_mainfile(filepath=broken, copy=True)
    status, out, err = _run(capfd, "stylize", "--blend", broken, *MIX)
    _refused(status, err, "Add the projector and camera first")
    assert "stylizing" not in out


def test_a_rig_deleted_while_generating_leaves_no_result(project, unchanged):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.generate.generate_job import GenerateJob

    bpy.ops.wm.open_mainfile(filepath=project.blend)
    scene = bpy.context.scene
    job = GenerateJob(scene_seams(scene), scene_state.generate_request(scene, prompt="x", mix="charcoal_wash:1", psa=False))
    job.check()  # started with the rig in place, as the Generate button does
    bpy.data.objects.remove(scene.lapig.projector)
    assert job.run() == "FAILED"
    assert str(job.error) == "Add the projector and camera first: the result was not kept"
    assert scene_state.read(scene).result_dir == project.result


@pytest.mark.torch  # eval, dataset and bench need torch before they read their inputs
def test_dev_commands_check_their_inputs_before_capturing(capfd, tmp_path):
    from lapig.lapig_core.common.imageio import write_png
    from lapig.lapig_core.common.surfaces import make_surface

    surface = tmp_path / "wood.png"
    write_png(surface, make_surface("wood", size=32, seed=3))
    out = tmp_path / "ev"
    for argv, message in ((["--prompt", "  "], "the prompt is empty"),
                          (["--prompt", "x", "--backend", "nope"], "unknown LGST backend 'nope'"),
                          (["--prompt", "x", "--train", "0"], "--train: Training images must be between 1 and 2000"),
                          (["--prompt", "x", "--psa-iterations", "0"], "--psa-iterations: PSA iterations must be")):
        status, _, err = _run(capfd, "eval", "--surface", surface, "--out", out, *argv)
        _refused(status, err, message)
        assert not out.exists()  # before the capture and the training (70 s at the default sizes)
    status, _, err = _run(capfd, "dataset", "--setups", "bench", "--train", "0", "--out", out)
    _refused(status, err, "--train: Training images must be between 1 and 2000")
    status, _, err = _run(capfd, "bench", "psa", "--backend", "nope", "--out", out)
    _refused(status, err, "unknown LGST backend 'nope'")
    assert not out.exists()


# -- what export exports ------------------------------------------------------------------------------


def test_export_after_a_stylize_without_save_says_which_result_to_export(capfd, project, new_results, tmp_path):
    status, _, err = _run(capfd, "stylize", "--blend", project.blend, "--prompt", "newer", "--mix",
                          "teal_red_mosaic:1", "--no-psa")
    assert status == 0, err[-2000:]
    (newer,) = new_results()
    assert f"note: this result is not saved into the .blend (no --save): export it with " \
           f"'export --result {newer}'" in err
    status, _, err = _run(capfd, "export", "--blend", project.blend, "--out", tmp_path / "p.png")
    line = _refused(status, err, f"the .blend holds {project.result}, but stylize made {newer} after it")
    assert f"--result {newer}" in line and os.listdir(tmp_path) == []  # not the old look with the old sidecar
    for result, prompt in ((newer, "newer"), (project.result, "x")):
        status, out, err = _run(capfd, "export", "--blend", project.blend, "--out", tmp_path / "p.png",
                                "--result", result, "--crossfade", tmp_path / "fade", "--frames", "3")
        assert status == 0, err[-2000:]
        assert json.loads((tmp_path / "p.json").read_text())["prompt"] == prompt
        assert json.loads(out.strip().splitlines()[-1])["result"] == result
        assert "wrote crossfade frame 3/3" in out  # the crossfade says how far it is


def test_notes_on_the_prompt_are_printed_and_reported(capfd, project, new_results):
    from lapig.operators.pipeline_ops import LAPIG_OT_generate

    # nothing of it understood: refused in one line before any work, and nothing changes (issue 50)
    before = _snapshot(project.folder)
    status, _, err = _run(capfd, "stylize", "--blend", project.blend, "--prompt",
                          "Mach es wie ein Zorblax, über dem stillen Meer", "--no-psa")
    line = _refused(status, err, "no look matched 'Zorblax stillen Meer': try ")
    assert new_results() == [] and _snapshot(project.folder) == before, line
    prompt = "Mach es wie ein Zorblax, über dem stillen Meer, in Blau, " * 12  # the colour is understood
    status, _, err = _run(capfd, "stylize", "--blend", project.blend, "--prompt", prompt, "--no-psa")
    assert status == 0, err[-2000:]
    notes = [line for line in err.splitlines() if line.startswith("note: ")]
    assert f"note: prompt truncated from {len(prompt.strip())} to 500 characters" in notes
    assert any(n.startswith("note: weak match") for n in notes), notes
    said = [n for n in notes if "'zorblax' matched no look" in n.lower()]
    assert len(said) == 1, notes  # once, though the prompt says it twelve times

    class Operator:  # the Generate operator's report, recorded
        reports = []

        def report(self, kind, message):
            self.reports.append((kind.pop(), message))

    (folder,) = new_results()
    summary = json.loads((Path(folder) / "result.json").read_text())
    job = type("Job", (), {"result": {"summary": summary, "summary_line": "ok"}})()
    LAPIG_OT_generate.on_done(Operator(), bpy.context, job)
    kinds = {message: kind for kind, message in Operator.reports}
    assert kinds[f"prompt truncated from {len(prompt.strip())} to 500 characters"] == "WARNING"
    assert any(kind == "WARNING" and m.startswith("weak match") for m, kind in kinds.items())


# -- Ctrl-C during torch work -------------------------------------------------------------------------


def _interrupt_when(marker, *argv, timeout=240):
    """Run the command and press Ctrl-C (SIGINT) once a stdout line holds `marker`: (status, stderr)."""
    proc = subprocess.Popen([sys.executable, "-m", "lapig_addon", *map(str, argv)], cwd=ROOT, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=_as_from_a_terminal)
    watchdog = threading.Timer(timeout, proc.kill)
    watchdog.start()
    try:
        for line in proc.stdout:
            if marker in line:
                proc.send_signal(signal.SIGINT)
                break
        _, err = proc.communicate()
    finally:
        watchdog.cancel()
    return proc.returncode, err


@pytest.mark.parametrize("argv, marker", [
    (["train", "--iterations", "5000"], "CompenNeSt: iteration"),  # fine-tuning, on the worker thread
    (["stylize", *MIX], "PSA iteration"),  # the surface adaptation, on the worker thread
])
def test_ctrl_c_during_torch_work_stops_cleanly(project, unchanged, argv, marker):
    status, err = _interrupt_when(marker, *argv, "--blend", project.blend)
    assert status == 130, err[-2000:]
    assert err.strip().splitlines()[-1] == "interrupted"
    assert "terminate called" not in err and "Traceback" not in err


# -- the operators' boundary and the panel's ranges ---------------------------------------------------


def test_an_unexpected_error_in_an_operator_is_one_line(project, monkeypatch, capfd, tmp_path):
    from lapig.lapig_addon.services.capture import capture_job
    from lapig.lapig_addon.services.export import export_result

    bpy.ops.wm.open_mainfile(filepath=project.blend)

    def broken(*args, **kwargs):
        raise KeyError("arch")

    def broken_steps(job):  # a job's steps are a generator: the failure comes from inside the job
        raise KeyError("arch")
        yield

    monkeypatch.setattr(export_result, "export_current", broken)
    with pytest.raises(RuntimeError) as refused:
        bpy.ops.lapig.export_image(filepath=str(tmp_path / "p.png"))
    assert str(refused.value).strip() == "Error: KeyError: 'arch'"
    monkeypatch.setattr(capture_job.CaptureJob, "steps", broken_steps)
    monkeypatch.setattr(bpy.app, "debug", True)  # blender --debug: the traceback on the console as well
    capfd.readouterr()
    with pytest.raises(RuntimeError) as refused:
        bpy.ops.lapig.capture()
    assert str(refused.value).strip() == "Error: LAPIG capture failed: KeyError: 'arch'"
    assert "Traceback" in capfd.readouterr().err
    assert os.listdir(tmp_path) == []


def test_the_panel_properties_have_the_ranges_the_command_line_checks(lapig_registered):
    from lapig.lapig_addon.services.limits import LIMITS
    from lapig.lapig_core.look_parameters import PARAMETERS

    properties = bpy.context.scene.lapig.bl_rna.properties
    shared = [name for name in LIMITS if name in properties]
    # every ranged scene setting (crossfade_fps: the live crossfade) and a world look's sliders; a rename shows here
    assert len(shared) == 12 + len(PARAMETERS)
    for name in shared:
        limit = LIMITS[name]
        assert properties[name].hard_min == pytest.approx(limit.low), name
        # no upper bound on the command line: none on the panel either (the property type's own)
        high = 2 ** 31 - 1 if limit.high is None else limit.high
        assert properties[name].hard_max == pytest.approx(high), name
