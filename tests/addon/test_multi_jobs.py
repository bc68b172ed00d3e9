"""Several projectors (issue 36) with bpy blocked: the capture job, its first look and the export against fakes of
the seams (the numpy fake rig of lapig_core/multi as the device), and the panel's decisions on a rig of several."""
import contextlib
import dataclasses
import importlib
import json
import os

import numpy as np
import pytest

from lapig.lapig_core.capture.settings import CaptureSettings
from lapig.tools.fakes import fake_rig

ADDON = "lapig.lapig_addon"
CAMERA, PROJECTOR = (96, 72), (48, 36)


def _module(name):
    return importlib.import_module(f"{ADDON}.services.{name}")


class MultiFactory:
    """The fake rig of two projectors as a device factory (multi=False: a rig that captures one projector only)."""

    main_thread = False

    def __init__(self, ports, rig, multi=True):
        self.ports, self.rig = ports, rig
        self.opens_several = multi  # declared: multi_capture_device opens both projectors at once

    def multi_capture_device(self, settings):
        return self._device(settings)

    def rig_identity(self):
        return self.ports.RigIdentity("fake rig of two", {"projectors": 2})

    @contextlib.contextmanager
    def _device(self, settings):
        yield fake_rig.FakeRigDevice(self.rig)


class MultiStore:
    """The scene's settings and what the jobs record, for a rig of two projectors."""

    def __init__(self, state, root, kind="VIRTUAL", displays=()):
        self.s, self.root, self.kind, self.displays = state, str(root), kind, displays
        self.capture_dir = self.fingerprint = ""
        self.coverage, self.models, self.result = None, "", ""

    def read(self):
        s = self.s
        rig = s.Rig(projector="Left", camera="Camera", target="Bust", scene="Scene", fingerprint="rig2",
                    projector_size=PROJECTOR, kind=self.kind, projectors=("Left", "Right"),
                    projector_sizes=(PROJECTOR, PROJECTOR), displays=self.displays)
        return s.SceneState(rig=rig, capture_dir=self.capture_dir, capture_fingerprint=self.fingerprint,
                            models_status=self.models, result_dir=self.result, result_fingerprint="rig2")

    def capture_settings(self, **overrides):
        return CaptureSettings(out_dir=os.path.join(self.root, "Bust"), setup_name="Bust", train_count=6, chunk=8)

    def data_root(self):
        return self.root

    def projector_models(self):
        from lapig.lapig_core.optics.projector_model import ProjectorModel

        return (ProjectorModel(width=PROJECTOR[0], height=PROJECTOR[1]),) * 2

    def rig_metadata(self):
        return {"camera": None, "surface_object": "Bust"}

    def software(self):
        return {"software_host": "tests"}

    def record_capture(self, folder, fingerprint, transport=""):
        self.capture_dir, self.fingerprint = str(folder), fingerprint

    def record_coverage(self, names, shares, reached):
        self.coverage = (tuple(names), tuple(shares), reached)

    def record_models(self, fingerprint, status=None):
        self.models = status

    def record_result(self, folder, summary_line, reach_message=""):
        self.result = str(folder)


@pytest.fixture
def multi(tmp_path):
    ports, state = _module("ports"), _module("state")
    store = MultiStore(state, tmp_path / "data")
    rig = fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.002)
    return ports.Seams(store, MultiFactory(ports, rig)), store


def test_the_capture_job_records_the_capture_its_coverage_and_the_first_look(multi):
    seams, store = multi
    job = _module("capture.capture_job").CaptureJob(seams, store.capture_settings())
    assert job.run() == "DONE", job.error
    assert os.path.isfile(os.path.join(store.capture_dir, "models", "joint_model.npz"))
    names, shares, reached = store.coverage
    assert names == ("Left", "Right") and reached > max(shares) + 0.15
    assert store.models.startswith("First look (joint classical model of 2 projectors)")
    assert job.result["first_look_seconds"] < 10
    assert job.line().startswith(f"Captured into {store.capture_dir}. First look")


def test_a_rig_that_captures_one_projector_refuses_several_in_one_line(tmp_path):
    ports, state = _module("ports"), _module("state")
    store = MultiStore(state, tmp_path / "data")
    seams = ports.Seams(store, MultiFactory(ports, fake_rig.side_by_side_rig(CAMERA, PROJECTOR), multi=False))
    job = _module("capture.capture_job").CaptureJob(seams, store.capture_settings())
    assert job.run() == "FAILED"
    assert str(job.error) == ("fake rig of two cannot capture several projectors yet: remove the other projectors, "
                              "or capture them with the virtual rig")
    assert store.capture_dir == ""


def test_the_panel_decides_on_a_rig_of_several(tmp_path):
    panel_state, state = _module("panel.panel_state"), _module("state")
    one = state.Rig(projector="P", camera="C", target="T")
    assert one.projector_count == 1 and panel_state.one_projector_blocker(one) == ""
    assert panel_state.projectors_blocker(one) == ""
    two = MultiStore(state, tmp_path).read().rig
    assert panel_state.one_projector_blocker(two) == "Works with one projector for now; the rig has 2"
    real = MultiStore(state, tmp_path, kind="REAL", displays=("1", "1")).read().rig
    assert panel_state.device_blocker(real) == "Projectors 'Left' and 'Right' are both on display '1': give each " \
                                               "its own display"
    apart = MultiStore(state, tmp_path, kind="REAL", displays=("1", "2")).read().rig
    assert panel_state.device_blocker(apart) == ""  # one window per display: a real rig of several captures
    unset = MultiStore(state, tmp_path, kind="REAL", displays=("1", "")).read().rig
    assert panel_state.device_blocker(unset) == "Choose projector 'Right''s display: each projector of a real rig " \
                                                "has its own"
    # a projector added after a capture of one: the capture is stale, and the panel says why
    folder = tmp_path / "capture"
    folder.mkdir()
    added = state.SceneState(rig=two, capture_dir=str(folder), capture_fingerprint="rig1")
    assert panel_state.capture_status(added).text == "Captured with 1 projector(s); the rig now has 2"
    assert panel_state.capture_blocker(added) == "The rig's projectors changed: capture again"
    # the preview modes of several: the same row as one projector's, every mode shown; Projection needs no result
    store = MultiStore(state, tmp_path)
    ungenerated = store.read()
    assert panel_state.preview_blocker(ungenerated, "TARGET") == "Generate a projector image first"
    assert panel_state.preview_blocker(ungenerated, "COMPENSABILITY") == "Generate a projector image first"
    assert panel_state.preview_blocker(ungenerated, "PROJECTION") == ""  # each light's own image, or the line
    store.result = str(folder)
    generated = store.read()
    modes = ("ORIGINAL", "PROJECTION", "TARGET", "SIMULATED", "RENDERED", "COMPENSABILITY", "LUX", "CONTRAST")
    assert [m for m in modes if panel_state.preview_blocker(generated, m)] == []
    unplaced = dataclasses.replace(generated, rig=dataclasses.replace(generated.rig, camera=None))
    assert panel_state.preview_blocker(unplaced, "PROJECTION") == "Add the projector and camera first"


def test_export_writes_each_projectors_image_and_refuses_a_package_it_cannot_write(multi, tmp_path):
    from lapig.lapig_core.multi.capture_set import load_multi_capture
    from lapig.lapig_core.multi.first_look import load_joint_model
    from lapig.lapig_core.multi.joint_solve import joint_compensate
    from lapig.lapig_core.multi.result_files import write_joint_result
    from lapig.lapig_core.multi.stylize import JointLook

    seams, store = multi
    assert _module("capture.capture_job").CaptureJob(seams, store.capture_settings()).run() == "DONE"
    cs = load_multi_capture(store.capture_dir, pairs=False)
    model = load_joint_model(cs.setup_dir)
    target = np.full(cs.together.shape, 0.4, np.float32)  # a flat grey look: no torch needed
    look = JointLook(target, joint_compensate(model, target), {"styles": []}, 1.0, 0.0)
    folder, _ = write_joint_result(tmp_path / "results", "grey", look, target, cs.names, cs.sizes,
                                   {"prompt": "grey", "capture": str(cs.setup_dir)}, model.reached.any(axis=0))
    store.result = str(folder)
    export = _module("export.export_result")
    state = _module("state")
    settings = state.ExportSettings(path=str(tmp_path / "out" / "grey.png"), bit_depth=16, crossfade_frames=4)
    (tmp_path / "out").mkdir()
    written = export.export_current(store, settings, mpcdi=str(tmp_path / "out" / "rig.mpcdi"))
    assert [os.path.basename(p) for p in written["images"]] == ["grey_1.png", "grey_2.png"]
    sidecar = json.loads(open(written["sidecars"][1]).read())
    assert sidecar["projector"] == {"index": 2, "count": 2, "name": "Right", "resolution": list(PROJECTOR)}
    assert sidecar["image"]["bit_depth"] == 16 and os.path.isfile(written["mpcdi"])
    assert "light" not in sidecar and "table" not in written  # no Light Report yet: as it always wrote
    # the 'sl' profile: the scene's geometry from the store (main thread), alphas from the joint model
    from lapig.tools.checks.mpcdi_read import read_mpcdi
    from lapig.lapig_core.optics.projector_model import ProjectorModel

    pm = ProjectorModel(width=PROJECTOR[0], height=PROJECTOR[1], throw_ratio=1.2)
    moved = np.eye(4)
    moved[:3, 3] = (0.5, -3.0, 1.0)
    store.sl_geometry = lambda step=8: {"models": [pm, pm], "matrices": [np.eye(4), moved],
                                        "points": [np.full((3, 4, 3), 0.25, np.float32)] * 2}
    sl = export.export_current(store, settings, mpcdi=str(tmp_path / "out" / "rig_sl.mpcdi"), images=False,
                               profile="sl")
    package = read_mpcdi(sl["mpcdi"])
    assert package.profile == "sl" and [b.id for b in package.buffers] == ["Left", "Right"]
    assert package.regions["Right region"].coordinate_frame.position == pytest.approx((0.5, -3.0, 1.0))
    assert package.regions["Left region"].coordinate_frame.roll_axis == pytest.approx((0.0, 0.0, -1.0))
    with pytest.raises(ValueError, match="MPCDI profile must be one of 2d, sl"):
        export.export_current(store, settings, mpcdi=str(tmp_path / "out" / "x.mpcdi"), profile="3d")
    # MPCDI 1.0 (Watchout 6, the VESA reference reader): both profiles follow the 1.0 text's rules
    from mpcdi_1_0_rules import problems  # tests/mpcdi_1_0_rules.py, written from the 1.0 text

    for profile in ("2d", "sl"):
        old = export.export_current(store, settings, mpcdi=str(tmp_path / "out" / f"rig_{profile}_1.mpcdi"),
                                    images=False, profile=profile, mpcdi_version="1.0")
        assert old["mpcdi_version"] == "1.0" and problems(old["mpcdi"]) == [], profile
    with pytest.raises(ValueError, match="MPCDI version must be one of 2.0, 1.0, got '3.0'"):
        export.export_current(store, settings, mpcdi=str(tmp_path / "out" / "x.mpcdi"), mpcdi_version="3.0")
    # after a Light Report of several: each sidecar its projector's share, the table every projector's row
    row = {"resolution": list(PROJECTOR), "lumens": 2000.0, "throw_ratio": 1.2, "shift_x": 0.0, "shift_y": 0.0,
           "position_m": [0, -3, 1], "rotation_deg": [90, 0, 0], "target_distance_m": 3.0, "target_lux": 250.0}
    report = {"lumens": 4000.0, "light_power_w": 200.0, "frame": "camera", "look_lux": {"mean": 300.0},
              "projectors": [{"name": "Left", "lumens": 2000.0, "share": 0.6},
                             {"name": "Right", "lumens": 2000.0, "share": 0.4}],
              "projector_table_rows": [{**row, "name": "Left"}, {**row, "name": "Right"}]}
    _module("light.light_report").write_report(str(folder), report)
    written = export.export_current(store, settings)
    sidecar = json.loads(open(written["sidecars"][1]).read())
    assert sidecar["light"]["lumens"] == 4000 and sidecar["light"]["projector"]["share"] == 0.4
    table = open(written["table"]).read()
    assert os.path.basename(written["table"]) == "grey_projectors.csv" and "Left" in table and "Right" in table
    # the one export of the scene's result takes the same path for a result of several
    assert _module("export.export_result").export_current(store, settings)["images"] == written["images"]
    blocked = tmp_path / "out" / "grey_1.png" / "rig.mpcdi"
    with pytest.raises(OSError, match="cannot write the MPCDI package"):
        export.export_current(store, state.ExportSettings(str(tmp_path / "out" / "again.png"), 16, 4),
                            mpcdi=str(blocked))
    assert not (tmp_path / "out" / "again_1.png").exists()  # the package first: nothing written on its failure
    # Export Crossfade of the result of several: a folder per projector, each its own crossfade (issue 36)
    frames = _module("export.export_result").export_crossfade(store, str(tmp_path / "fade"), settings)
    assert len(frames) == 8 and sorted(os.listdir(tmp_path / "fade")) == ["projector_1", "projector_2"]
    faded = json.loads((tmp_path / "fade" / "projector_2" / "crossfade.json").read_text())
    assert faded["projector"]["name"] == "Right" and faded["light"]["projector"]["share"] == 0.4  # its own share


def test_refine_corrects_every_projectors_image_together_and_the_result_points_at_them(tmp_path):
    """Refine on a rig of several: a weak open-loop result (each image's light at 80 %: a model's error) projected
    by all the projectors at once, captured, corrected jointly; result.json then names the refined images."""
    import cv2

    from lapig.lapig_core.multi.capture_set import load_multi_capture
    from lapig.lapig_core.multi.first_look import load_joint_model
    from lapig.lapig_core.multi.joint_solve import joint_compensate, reach
    from lapig.lapig_core.multi.result_files import projector_images, write_joint_result
    from lapig.lapig_core.multi.stylize import JointLook

    ports, state = _module("ports"), _module("state")

    class Store(MultiStore):
        def export_settings(self):
            return state.ExportSettings(path="", bit_depth=16, crossfade_frames=4)

    class Sink:
        several_projectors = True

        def __init__(self):
            self.frames = []

        def show(self, frame):
            self.frames.append(frame)

    store, sink = Store(state, tmp_path / "data"), Sink()
    seams = ports.Seams(store, MultiFactory(ports, fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.002)), (sink,))
    assert _module("capture.capture_job").CaptureJob(seams, store.capture_settings()).run() == "DONE"
    cs = load_multi_capture(store.capture_dir, pairs=False)
    model = load_joint_model(cs.setup_dir)
    lo, hi = reach(model)
    pattern = cv2.resize(np.random.default_rng(4).random((3, 4, 3)).astype(np.float32), CAMERA,
                         interpolation=cv2.INTER_CUBIC).clip(0, 1)
    target = lo + (hi - lo) * (0.15 + 0.7 * pattern)
    comp = joint_compensate(model, target)
    comp.frames = [f * 0.8 ** (1 / g) for f, g in zip(comp.frames, model.gamma_p)]  # 80 % of the light
    look = JointLook(target, comp, {"styles": []}, 1.0, 0.0)
    folder, _ = write_joint_result(tmp_path / "results", "look", look, target, cs.names, cs.sizes,
                                   {"prompt": "look", "capture": str(cs.setup_dir), "summary_line": "look"},
                                   model.reached.any(axis=0))
    store.result = str(folder)
    scene = store.read()
    panel_state = _module("panel.panel_state")
    assert panel_state.refine_blocker(scene) == ""  # Refine lets a rig of several through now
    assert panel_state.render_blocker(scene) == ""  # Render Real Capture too
    # the crossfade and the preview modes still want one projector
    assert panel_state.single_result_blocker(scene) == "Works with one projector for now; the rig has 2"
    job = _module("refine.refine_job").RefineResultJob(seams, 4)
    assert job.run() == "DONE", job.error
    record = job.result["refine"]
    assert record["refined_psnr"] > record["open_loop_psnr"] + 3.0, record
    saved = json.loads((folder / "result.json").read_text())
    assert [p["image"] for p in saved["projectors"]] == ["projector_1_refined.png", "projector_2_refined.png"]
    assert [p["image_open_loop"] for p in saved["projectors"]] == ["projector_1.png", "projector_2.png"]
    assert saved["refine"]["images"] == {"projector_1": "projector_1_refined.png",
                                         "projector_2": "projector_2_refined.png"}
    assert "; refined " in saved["summary_line"] and store.result == str(folder)
    # Export and the lights read the refined images, and each light was shown its own
    refined = [image for _, image in projector_images(folder)]
    assert not np.allclose(refined[0], comp.frames[0], atol=2 / 255)
    assert [f.projector_index for f in sink.frames] == [0, 1]
    # a real rig of several shows them all at once, one window per display: refined as the virtual one; two on
    # one display are refused in the panel's words
    real = MultiStore(state, tmp_path, kind="REAL", displays=("1", "2"))
    real.result = str(folder)
    assert panel_state.refine_blocker(real.read()) == ""
    shared = MultiStore(state, tmp_path, kind="REAL", displays=("1", "1"))
    shared.result = str(folder)
    assert panel_state.refine_blocker(shared.read()).endswith("are both on display '1': give each its own display")


@pytest.mark.torch  # render_job scores with common/metrics, which loads torch
def test_render_real_capture_of_several_shows_every_image_at_once_and_scores_it_on_the_object(tmp_path):
    """Render Real Capture on a rig of several: both projectors' images of the result shown together, captured
    once in camera space; rendered.png and its PSNR against the look (and the predicted capture) go into the
    result, its comparison sheet shows it, and the rendered capture is close to the joint model's prediction."""
    from lapig.lapig_core.common.imageio import read_image
    from lapig.lapig_core.multi.capture_set import load_multi_capture
    from lapig.lapig_core.multi.first_look import load_joint_model
    from lapig.lapig_core.multi.joint_solve import joint_compensate, reach
    from lapig.lapig_core.multi.result_files import write_joint_result
    from lapig.lapig_core.multi.stylize import JointLook

    ports, state = _module("ports"), _module("state")
    store = MultiStore(state, tmp_path / "data")
    seams = ports.Seams(store, MultiFactory(ports, fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.002)))
    assert _module("capture.capture_job").CaptureJob(seams, store.capture_settings()).run() == "DONE"
    cs = load_multi_capture(store.capture_dir, pairs=False)
    model = load_joint_model(cs.setup_dir)
    lo, hi = reach(model)
    ramp = np.linspace(0.2, 0.8, CAMERA[0], dtype=np.float32)[None, :, None] * np.ones((CAMERA[1], 1, 3), np.float32)
    target = lo + (hi - lo) * ramp
    look = JointLook(target, joint_compensate(model, target), {"styles": []}, 1.0, 0.0)
    folder, _ = write_joint_result(tmp_path / "results", "look", look, target, cs.names, cs.sizes,
                                   {"prompt": "look", "capture": str(cs.setup_dir), "summary_line": "look"},
                                   model.reached.any(axis=0))
    store.result = str(folder)
    job = _module("render.render_job").RenderResultJob(seams)
    assert job.run() == "DONE", job.error
    m = job.result["metrics"]
    print("rendered", m["rendered_psnr"], "vs predicted", m["rendered_vs_predicted_psnr"], "simulated",
          m["simulated_psnr"])
    # a look within the joint reach: the prediction is exact (simulated_psnr ~ inf), the render is within the
    # camera's noise and 8-bit frames of it (about 33 dB here)
    assert np.isfinite(m["rendered_psnr"]) and m["rendered_psnr"] > 28.0
    assert m["rendered_vs_predicted_psnr"] > 28.0  # the model foresaw the render
    rendered = read_image(folder / "rendered.png")
    assert rendered.shape == (CAMERA[1], CAMERA[0], 3) and rendered.mean() > 0.05
    saved = json.loads((folder / "result.json").read_text())
    assert saved["metrics"]["rendered_psnr"] == pytest.approx(m["rendered_psnr"])
    assert saved["projectors"][0]["image"] == "projector_1.png"  # the result itself untouched
    assert saved["summary_line"].endswith(f"; no PSA; rendered in Cycles {m['rendered_psnr']:.1f} dB against the look")
    assert store.result == str(folder)
    # rendered again: one figure in the line, the newest
    assert _module("render.render_job").RenderResultJob(seams).run() == "DONE"
    assert json.loads((folder / "result.json").read_text())["summary_line"].count("rendered in Cycles") == 1
    sheet = read_image(folder / "comparison.png")
    assert sheet.shape[1] == 3 * 256  # look, predicted, rendered; the projectors below
    # the left and right halves are each lit by their own projector: both bright where the look is
    assert rendered[:, : CAMERA[0] // 3].mean() > 0.02 and rendered[:, -CAMERA[0] // 3:].mean() > 0.02
    # a refinement afterwards keeps the sheet of several (look, predicted, rendered; the projectors below)
    assert _module("refine.refine_job").RefineResultJob(seams, 1).run() == "DONE"
    assert read_image(folder / "comparison.png").shape == sheet.shape


@pytest.mark.torch
@pytest.mark.parametrize("psa", [True, False])
def test_generate_adapts_the_look_to_the_joint_reach_when_asked(multi, psa):
    """GenerateJob of several passes the request's PSA on: with it the folder keeps the look without PSA beside the
    adapted one, and result.json says what PSA did; without it, one look and 'no PSA'."""
    seams, store = multi
    assert _module("capture.capture_job").CaptureJob(seams, store.capture_settings()).run() == "DONE"
    request = _module("state").GenerateRequest("Make it a stained glass artwork", "styletransfer", "", psa, 0.5, 0)
    job = _module("generate.generate_job").GenerateJob(seams, request, working_size=48)
    assert job.run() == "DONE", job.error
    folder = job.result["folder"]
    saved = json.loads(open(os.path.join(folder, "result.json")).read())
    nopsa = [os.path.isfile(os.path.join(folder, f"{n}_nopsa.png")) for n in ("look", "projector_1", "projector_2")]
    if psa:
        assert all(nopsa) and saved["psa"]["settings"]["adaptation"] == 0.5 and saved["psa"]["warm_start_steps"] > 0
        assert "PSA on their joint reach" in saved["summary_line"]
        assert saved["metrics"]["simulated_psnr"] > saved["metrics"]["simulated_psnr_nopsa"]
    else:
        assert not any(nopsa) and saved["psa"] is False and saved["summary_line"].endswith("no PSA")
    assert store.result == folder


@pytest.mark.torch
def test_a_show_of_several_makes_its_morph_and_motion_per_projector_and_exports_each(multi, tmp_path):
    """Issues 36 and 38 where they meet: a show of two looks of the rig of two, a morph into a drifting look, is made
    by lapig_core's producer on the joint reach (show/joint_setup), one frame per projector; the holds are the
    looks' own images, the in-betweens new ones; Export Show writes one sequence per projector."""
    seams, store = multi
    assert _module("capture.capture_job").CaptureJob(seams, store.capture_settings()).run() == "DONE"
    folders = []
    for prompt in ("Make it a stained glass artwork", "Make it a charcoal sketch"):
        request = _module("state").GenerateRequest(prompt, "styletransfer", "", True, 0.5, 0)
        job = _module("generate.generate_job").GenerateJob(seams, request, working_size=48)
        assert job.run() == "DONE", job.error
        folders.append(job.result["folder"])
        assert os.path.isfile(os.path.join(job.result["folder"], "look_state.npz"))  # PSA's state, for the show
    show_plan, show_source, show_jobs = _module("show.show_plan"), _module("show.show_source"), _module("show.show_jobs")
    plan = show_plan.ShowPlan(looks=(
        show_plan.ShowLook(result_dir=folders[0], hold_s=0.3, transition="morph", transition_s=0.4),
        show_plan.ShowLook(result_dir=folders[1], hold_s=0.5, motion="drift", motion_amount=0.6)), fps=10.0)
    source = show_source.ShowSource(plan, projectors=store.projector_models(), bit_depth=16,
                                    capture_dir=store.capture_dir)
    assert show_source.uses_producer(source) and show_source.fallback_notes(source) == []
    frames = [pixels for _, pixels in show_source.frames(source)]
    assert len(frames) == plan.frame_count() == 12
    assert all([p.shape for p in f] == [PROJECTOR[::-1] + (3,)] * 2 and f[0].dtype == np.uint16 for f in frames)
    from lapig.lapig_core.multi.result_files import projector_images

    stored = [image for _, image in projector_images(folders[0])]
    for got, want in zip(frames[0], stored):  # look 1's hold is its result's image, made again from its state
        assert np.abs(got / 65535.0 - want).mean() < 2 / 255
    held_a, held_b = frames[0], frames[7]
    morph = frames[4]  # frames 3..6 morph from look 1 into look 2
    for k in range(2):
        assert np.abs(morph[k].astype(float) - held_a[k]).mean() > 300
        assert np.abs(morph[k].astype(float) - held_b[k]).mean() > 300
    assert any(np.abs(frames[8][k].astype(float) - frames[11][k]).mean() > 100 for k in range(2))  # it drifts
    job = show_jobs.ShowExportJob(source, str(tmp_path / "show"), "png")
    assert job.run() == "DONE", job.error
    for k in (1, 2):
        pngs = sorted(n for n in os.listdir(tmp_path / "show" / f"show_{k}") if n.endswith(".png"))
        assert len(pngs) == 12
    # a show of holds and a dissolve plays the stored images; its dissolve is compensated jointly at its keys
    plain = show_plan.ShowPlan(looks=(
        show_plan.ShowLook(result_dir=folders[0], hold_s=0.1, transition="dissolve", transition_s=0.8),
        show_plan.ShowLook(result_dir=folders[1], hold_s=0.1)), fps=10.0)
    keyed = show_source.ShowSource(plain, projectors=store.projector_models(), bit_depth=16,
                                   capture_dir=store.capture_dir)
    crossfade = show_source.ShowSource(plain, projectors=store.projector_models(), bit_depth=16,
                                       capture_dir=store.capture_dir, compensated_dissolves=False)
    assert not show_source.uses_producer(keyed)
    made = {i: p for i, p in show_source.frames(keyed)}
    faded = {i: p for i, p in show_source.frames(crossfade)}
    assert all(np.array_equal(made[0][k], faded[0][k]) for k in range(2))  # the holds: the stored images
    mid = 5  # frames 1..8 dissolve (w = 1/9 .. 8/9): frame 5 at 5/9, between the keys at 1/2 and 3/4
    assert any(np.abs(made[mid][k].astype(float) - faded[mid][k]).mean() > 50 for k in range(2))


@pytest.mark.torch
def test_a_world_look_of_several_projectors_is_shaped_by_the_object_as_the_camera_sees_it(multi):
    """GenerateJob of several reads the store's camera-space geometry (Blender's casts from the rig's camera; here a wall
    with a step) on the main thread and hands it to the look of the world; without one the look reads none."""
    from lapig.lapig_core.lgst.world.geometry import from_hits

    seams, store = multi
    assert _module("capture.capture_job").CaptureJob(seams, store.capture_settings()).run() == "DONE"
    asked = []

    def wall(long_side):
        asked.append(long_side)
        width, height = long_side, long_side * CAMERA[1] // CAMERA[0]
        ys, xs = np.mgrid[0:height, 0:width] + 0.5
        depth = np.where(xs < width / 2, 3.0, 4.0)
        f = float(width)
        points = np.stack([(xs - width / 2) / f * depth, (ys - height / 2) / f * depth, depth], -1)
        normals = np.broadcast_to(np.array([0.0, 0.0, -1.0]), points.shape).copy()
        return from_hits(points, normals, np.array([0.0, -1.0, 0.0]), f, f, width / 2, height / 2)

    def generate(prompt):
        request = _module("state").GenerateRequest(prompt, "styletransfer", "", False, 0.5, 0)
        job = _module("generate.generate_job").GenerateJob(seams, request, working_size=48)
        assert job.run() == "DONE", job.error
        return json.loads(open(os.path.join(job.result["folder"], "result.json")).read())

    store.camera_look_geometry = wall
    assert generate("old bricks")["lgst"]["geometry"]["source"] == "scene" and asked == [48]
    assert "geometry" not in generate("Make it a stained glass artwork")["lgst"]  # an art look reads none
    del store.camera_look_geometry
    assert "geometry" not in generate("old bricks")["lgst"]
