"""The light plan and report without Blender: input checks, the report on fake maps, the cap, Export's
additions (the sidecar's figures and the projector table)."""
import importlib
import json
from types import SimpleNamespace

import numpy as np
import pytest

from lapig.lapig_core.optics.projector_model import ProjectorModel
from lapig.lapig_core.photometry import dose


@pytest.fixture
def lr():
    return importlib.import_module("lapig.lapig_addon.services.light.light_report")


@pytest.fixture
def sidecar():
    return importlib.import_module("lapig.lapig_addon.services.light.light_sidecar")


def _maps(white=400.0, room=20.0, region_rows=slice(0, 8)):
    on = np.ones((8, 10), bool)
    region = np.zeros((8, 10), bool)
    region[region_rows] = True
    white_lux = np.full((8, 10), white)
    white_lux[:, 5:] = white * 0.8
    return SimpleNamespace(white_lux=white_lux, ambient_lux=np.full((8, 10), room), albedo=np.full((8, 10), 0.5),
                           on_object=on, region=region)


@pytest.mark.parametrize("plan,match", [
    (dict(), "lumens, or choose a projector preset"),
    (dict(lumens=-100), "more than 0 lumens"),
    (dict(lumens=0, preset="nope"), "no projector preset 'nope'"),
    (dict(lumens=1000, ambient_lux=-2), "0 lux or more"),
    (dict(lumens=1000, lamp_direction=(0, 0, 0)), "not all 0"),
    (dict(lumens=1000, contrast=0.5), "more than 1:1"),
    (dict(lumens=1000, region_material="gold", region_group="paper"), "not both"),
    (dict(lumens=1000, limit=dose.ConservationLimit("high", schedule=dose.Schedule(26, 200))), "at most 24"),
])
def test_bad_plans_say_why(lr, plan, match):
    problem = lr.LightPlan(**plan).problem()
    assert match in problem
    with pytest.raises(ValueError, match=match.split(",")[0]):
        lr.LightPlan(**plan).check()


def test_a_preset_supplies_lumens_and_contrast(lr):
    plan = lr.LightPlan(preset="epson-eb-g5350")
    assert plan.problem() == "" and plan.resolved_lumens == 5000 and plan.resolved_contrast == 1000
    assert lr.LightPlan(preset="epson-eb-g5350", lumens=4000).resolved_lumens == 4000


def test_report_of_a_look_with_a_dose(lr):
    limit = dose.ConservationLimit("high", schedule=dose.Schedule(10, 200))
    plan = lr.LightPlan(lumens=2000, ambient_lux=20, limit=limit)
    emitted = np.full((8, 10), 0.25)
    report = lr.light_report(plan, _maps(region_rows=slice(0, 4)), emitted, ProjectorModel())
    assert report["look_lux"]["max"] == pytest.approx(100.0)
    assert report["dose"]["max_lux"] == pytest.approx(120.0) and not report["dose"]["within_limit"]
    assert report["dose"]["lux_hours_per_year_max"] == 120 * 2000
    # 30 lux of the look may stay where 100 are now (50 - 20 of room light): 30% of the lumens
    assert report["dose"]["lumens_within_limit"] == 600
    assert report["light_power_w"] > 0 and report["warning"] == ""  # 400 lux white in a 20 lux room: 21:1
    json.dumps(report)  # plain JSON


def test_a_region_the_projector_misses_is_refused(lr):
    plan = lr.LightPlan(lumens=2000, limit=dose.ConservationLimit("high"), region_material="gold")
    with pytest.raises(ValueError, match="no faces"):  # DoseError, of the add-on's copy of lapig_core
        lr.light_report(plan, _maps(region_rows=slice(0, 0)), None, ProjectorModel())


def test_the_capped_frame_keeps_the_region_within_the_limit(lr):
    model = ProjectorModel(10, 8)
    maps = _maps(white=900.0, room=5.0, region_rows=slice(2, 6))
    plan = lr.LightPlan(lumens=3000, ambient_lux=5, limit=dose.ConservationLimit("high"))
    frame = np.full((8, 10, 3), 200 / 255)
    capped, info = lr.capped_frame(plan, frame, maps.white_lux, maps.ambient_lux, maps.region, model)
    from lapig.lapig_core.photometry.units import LUMA

    lux = maps.white_lux * (model.emitted(capped) @ LUMA) + maps.ambient_lux  # what a lux meter reads
    assert lux[maps.region].max() <= 50 and np.allclose(capped[~maps.region], frame[~maps.region])
    assert info["changed_pixel_share"] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="conservation category"):
        lr.capped_frame(lr.LightPlan(lumens=3000), frame, maps.white_lux, 5.0, maps.region, model)


def test_export_adds_the_light_figures_and_the_table(lr, sidecar, tmp_path):
    assert sidecar.sidecar_fields(tmp_path) == {} and sidecar.write_table_beside(tmp_path / "x.png", tmp_path) is None
    plan = lr.LightPlan(preset="optoma-ml500", ambient_lux=100, limit=dose.ConservationLimit("moderate"))
    report = lr.light_report(plan, _maps(white=200.0, room=100.0), None, ProjectorModel())
    report["projector_table_row"] = {"name": "LAPIG Projector", "maker": "Optoma", "model": "ML500",
                                     "resolution": [800, 600], "lumens": 500, "throw_ratio": 1.55, "shift_x": 0,
                                     "shift_y": 0, "position_m": [0, -2.8, 1], "rotation_deg": [90, 0, 0],
                                     "target_distance_m": 2.82, "target_lux": 180.0}
    lr.write_report(tmp_path, report)
    fields = sidecar.sidecar_fields(tmp_path)["light"]
    assert fields["lumens"] == 500 and fields["dose"]["limit_lux"] == 200 and "below 5:1" in fields["warning"]
    assert fields["preset"]["id"] == "optoma-ml500"
    table = sidecar.write_table_beside(tmp_path / "look.png", tmp_path)
    assert table.name == "look_projectors.csv"
    assert "LAPIG Projector,Optoma,ML500,800,600,500," in table.read_text()


def test_the_capped_look_is_a_result_of_its_own(tmp_path):
    from lapig.lapig_core.export.result_files import write_result

    dc = importlib.import_module("lapig.lapig_addon.services.light.dose_cap")
    free = tmp_path / "20261204_look"
    frame = np.full((12, 16, 3), 0.8, np.float32)
    write_result(free, {"projector": frame[:8, :8], "projector_native": frame, "target": frame[:8, :8]},
                 {"prompt": "look"})
    (free / "light_report.json").write_text("{}")
    capped = np.full((12, 16, 3), 0.3, np.float32)
    new = dc.write_capped_result(free, capped, {"limit_lux": 50.0})
    assert new.name == "20261204_look_dose_cap" and not (new / "light_report.json").exists()
    from lapig.lapig_core.export.result_files import read_output_image, read_summary

    assert np.allclose(read_output_image(new, "projector"), 0.3, atol=1e-4)
    assert np.allclose(read_output_image(free, "projector"), 0.8, atol=1e-4)  # the free look stays
    assert read_summary(new)["dose_cap"]["capped_from"] == str(free)
    with pytest.raises(ValueError, match="not the projector's native frame"):
        dc.write_capped_result(free, capped[:6], {})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["20261204_look", "20261204_look_dose_cap"]


def test_a_preset_shapes_the_projector_and_says_what_it_cannot_keep(lr):
    model = ProjectorModel(800, 600, throw_ratio=1.5, shift_y=0.9)
    settings, notes = lr.projector_settings(lr.LightPlan(preset="optoma-wu1500"), model)
    assert (settings["resolution_x"], settings["resolution_y"]) == (1920, 1200)
    assert settings["throw_ratio"] == pytest.approx(1.54) and settings["shift_y"] == pytest.approx(0.6)
    assert settings["black_level"] == pytest.approx(1 / 2000)
    assert any("throws 1.54 to 1.93" in n for n in notes) and any("lens shift" in n for n in notes)
    shaped = ProjectorModel(1920, 1200, 1.54, shift_y=0.6)
    from lapig.lapig_core.photometry import units

    assert settings["brightness"] == pytest.approx(units.lumens_to_watts(15000, shaped))
    plain, notes = lr.projector_settings(lr.LightPlan(lumens=2000), model)
    assert notes == [] and "resolution_x" not in plain and plain["throw_ratio"] == 1.5


class _SceneLight:
    """blender/light_plan_run.SceneLight's fake: flat light maps at the projector's size, one render a step, and
    whether the capture's lock was held (by someone) while each was rendered."""

    strategy = "projector-space"  # services/state.PROJECTOR_SPACE: the maps in the projector's frame

    def __init__(self, model, capture_root):
        self.model, self.capture_root = model, capture_root
        self.size, self.scale, self.target_name = (16, 12), 1.0, "Wall"
        self.row = {"name": "LAPIG Projector", "resolution": [model.width, model.height]}
        self.renders = []
        self.decoded = []  # the threads the passes became maps on

    def _lock_held(self) -> bool:
        from lapig.lapig_core.common.locking import FolderBusy, FolderLock

        try:
            FolderLock(self.capture_root, "the test").acquire().release()
        except FolderBusy:
            return True
        return False

    def _passes(self, width, height):
        import threading

        light = self

        class Passes:
            def maps(self):
                light.decoded.append(threading.current_thread().name)
                white = np.full((height, width), 900.0)
                region = np.zeros((height, width), bool)
                region[height // 4: 3 * height // 4] = True
                return SimpleNamespace(white_lux=white, ambient_lux=np.full((height, width), 5.0),
                                       albedo=np.full((height, width), 0.5), on_object=np.ones((height, width), bool),
                                       region=region)

            def discard(self):
                pass

        return Passes()

    def room_steps(self, start=0.0, end=1.0):
        yield start, "rendering the projector's light"
        self.renders.append(("room", self._lock_held()))
        return self._passes(*self.size)

    def native_steps(self, start=0.0, end=1.0):
        yield start, "rendering the projector's light at its native size"
        self.renders.append(("native", self._lock_held()))
        return self._passes(self.model.width, self.model.height)


def test_limit_look_to_the_dose_is_a_job_under_the_captures_lock_and_measures_on_the_factorys_device(seams, tmp_path):
    from lapig.lapig_core.capture.dataset import resolve_setup
    from lapig.lapig_core.common.locking import FolderLock
    from lapig.lapig_core.export.result_files import read_output_image, read_summary, write_new_result

    lr = importlib.import_module("lapig.lapig_addon.services.light.light_report")
    dc = importlib.import_module("lapig.lapig_addon.services.light.dose_cap")
    capture_job = importlib.import_module("lapig.lapig_addon.services.capture.capture_job")
    captured = capture_job.CaptureJob(seams, seams.store.capture_settings(train_count=4, test_count=0)).run_to_completion()
    model = seams.store.projector_model()
    look = np.full((model.height, model.width, 3), 0.9, np.float32)
    free = write_new_result(tmp_path / "results", "look", {"projector": look, "target": look * 0.8},
                            {"prompt": "a look", "summary_line": "a look; simulated 30.0 dB"})
    seams.store.record_result(str(free), "a look; simulated 30.0 dB")
    root = resolve_setup(captured["setup_dir"]).root
    light = _SceneLight(model, root)
    plan = lr.LightPlan(lumens=3000, ambient_lux=5, limit=dose.ConservationLimit("high"))
    factory = seams.devices
    opened = factory.opened
    out = dc.DoseCapJob(seams, plan, light, measure_psnr=True).run_to_completion()

    assert light.renders == [("room", True), ("native", True)]  # the capture's folder held by the job
    FolderLock(root, "the test").acquire().release()  # and let go of at the end
    assert factory.opened == opened + 1 and factory.closed == factory.opened  # the rig opened once, and closed
    assert f"LAPIG: {dc.DoseCapJob.title}" in factory.threads  # by the job, on a worker as the factory asks
    assert "psnr_cost_db" in out and out["psnr_free_db"] > 0  # both frames projected on the factory's rig
    new = out["folder"]
    assert seams.store.result[:2] == (new, "a look; simulated 30.0 dB | limited to the light dose")
    import threading

    assert lr.read_report(new)["result"] == new  # its light report written, on the room maps rendered once
    assert len(light.decoded) == 2 and threading.main_thread().name not in light.decoded
    capped = read_output_image(new, "projector")
    np.testing.assert_array_equal(seams.sinks[0].frames[-1].image, capped)  # the light and the live window show it
    assert capped.max() < 0.9 and read_summary(new)["dose_cap"]["capped_from"] == str(free)


class _Passes:
    """blender/light_render's LightPasses' fake: the renders' files, turned into flat maps where maps() runs."""

    def __init__(self, light, width, height):
        self.light, self.width, self.height = light, width, height
        self.discarded = False

    def maps(self):
        import threading

        self.light.decoded.append(threading.current_thread().name)
        w, h = self.width, self.height
        white = np.full((h, w), 450.0)  # at the light's power: scale makes it the plan's
        white[:, w // 2:] = 360.0
        region = np.zeros((h, w), bool)
        region[h // 4: 3 * h // 4] = True
        return SimpleNamespace(white_lux=white, ambient_lux=np.full((h, w), 5.0), albedo=np.full((h, w), 0.5),
                               on_object=np.ones((h, w), bool), region=region)

    def discard(self):
        self.discarded = True


class _ReportLight:
    """blender/light_plan_run.SceneLight's fake for the report: read from the scene when made; each Cycles
    render a step of its own (the thread that ran each one recorded); the passes' arithmetic where maps() runs."""

    strategy = "projector-space"

    def __init__(self, model, size=(16, 12)):
        self.model, self.size, self.scale, self.target_name = model, size, 2.0, "Wall"
        self.row = {"name": "LAPIG Projector", "maker": "", "model": "", "resolution": [model.width, model.height],
                    "lumens": 2000.0, "throw_ratio": 1.5, "shift_x": 0.0, "shift_y": 0.0,
                    "position_m": (0.0, -3.0, 1.0), "rotation_deg": (90.0, 0.0, 0.0), "target_distance_m": 3.0}
        self.renders = []  # (which, the thread it ran on)
        self.decoded = []  # the threads the passes became maps on
        self.passes = []

    def room_steps(self, start=0.0, end=1.0):
        import threading

        yield start, "rendering the projector's light"
        self.renders.append(("white", threading.current_thread().name))
        yield (start + end) / 2, "rendering the room's light"
        self.renders.append(("room", threading.current_thread().name))
        self.passes.append(_Passes(self, *self.size))
        return self.passes[-1]


def _report_folder(tmp_path, model):
    from lapig.lapig_core.export.result_files import write_new_result

    look = np.full((model.height, model.width, 3), 0.6, np.float32)
    look[:, : model.width // 2] = 0.9
    return write_new_result(tmp_path / "results", "look", {"projector": look, "target": look}, {"prompt": "a look"})


REPORT_FILES = ["light_contrast.png", "light_luminance.png", "light_lux.png", "light_report.json"]


def test_light_report_is_a_job_whose_arithmetic_and_files_are_off_the_main_thread(tmp_path, monkeypatch):
    """Issue 35: the renders are the job's main-thread steps, one a step; the maps' arithmetic, the report and
    its files are a worker's, each file written whole (a temporary file renamed into place)."""
    import os
    import threading

    from lapig.lapig_core.photometry import light_maps

    job_module = importlib.import_module("lapig.lapig_addon.services.light.light_report_job")
    lr = importlib.import_module("lapig.lapig_addon.services.light.light_report")
    model = ProjectorModel(64, 48)
    folder = _report_folder(tmp_path, model)
    light = _ReportLight(model)
    plan = lr.LightPlan(lumens=2000, ambient_lux=5, limit=dose.ConservationLimit("high"))
    main = threading.main_thread().name
    threads = {"arithmetic": set(), "renamed": {}}

    def seen(function):
        def wrapper(*args, **kwargs):
            threads["arithmetic"].add(threading.current_thread().name)
            return function(*args, **kwargs)
        return wrapper

    for name in ("light_summary", "lux_colour_map", "contrast_colour_map"):
        monkeypatch.setattr(light_maps, name, seen(getattr(light_maps, name)))
    replace = os.replace

    def replace_and_see(src, dst, *args, **kwargs):
        threads["renamed"][os.fspath(dst)] = (threading.current_thread().name, os.path.basename(os.fspath(src)))
        return replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", replace_and_see)
    job = job_module.LightReportJob(plan, light, str(folder), maps_dir=str(tmp_path / "maps"))
    steps = 0
    while job.step():  # one render a step, so the UI redraws (and Esc cancels) between them
        rendered = len(light.renders)
        steps += 1
        assert rendered <= steps
        if rendered < 2:
            assert len(light.renders) == rendered
    assert job.state == "DONE", job.message
    report = job.result

    assert [(which, thread) for which, thread in light.renders] == [("white", main), ("room", main)]
    assert light.decoded and main not in light.decoded and light.passes[0].discarded
    assert threads["arithmetic"] and main not in threads["arithmetic"], threads["arithmetic"]
    written = {os.path.relpath(dst, tmp_path): info for dst, info in threads["renamed"].items()}
    names = [os.path.join(os.path.relpath(folder, tmp_path), f) for f in REPORT_FILES]
    names += [os.path.join("maps", f) for f in REPORT_FILES[:3]]
    assert sorted(written) == sorted(names)
    for path, (thread, temporary) in written.items():
        assert thread != main and temporary.endswith(".tmp"), (path, thread, temporary)
    assert sorted(p.name for p in folder.iterdir() if p.name.startswith("light_")) == REPORT_FILES
    assert not [p for p in folder.iterdir() if p.name.startswith(".")]  # no temporary file left

    # the figures: the passes scaled to the plan's lumens, the look's light on them
    assert report["report_file"] == os.path.join(str(folder), "light_report.json")
    assert report["result"] == str(folder) and report["maps"] == str(tmp_path / "maps")
    saved = lr.read_report(folder)
    assert saved == json.loads(json.dumps({k: v for k, v in report.items() if k != "report_file"}))
    assert report["white_lux"]["max"] == pytest.approx(900.0) and report["dose"]["limit_lux"] == 50
    assert report["projector_table_row"]["target_lux"] == pytest.approx(810.0)
    brightest = lr.emitted_luma(model, lr.native_frame(folder, model)).max()  # the look's frame, not a white one
    assert report["look_lux"]["max"] == pytest.approx(900.0 * brightest, abs=0.01) and brightest < 0.9


def test_a_cancelled_light_report_leaves_the_previous_report_as_it_was(tmp_path):
    """Esc between two renders: the job ends there, nothing is computed or written, the report files of the last
    run stay byte for byte."""
    job_module = importlib.import_module("lapig.lapig_addon.services.light.light_report_job")
    lr = importlib.import_module("lapig.lapig_addon.services.light.light_report")
    model = ProjectorModel(64, 48)
    folder = _report_folder(tmp_path, model)
    for i, name in enumerate(REPORT_FILES):
        (folder / name).write_bytes(f"the previous {name} {i}".encode())
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    light = _ReportLight(model)
    plan = lr.LightPlan(lumens=2000, ambient_lux=5)
    job = job_module.LightReportJob(plan, light, str(folder), maps_dir=str(tmp_path / "maps"))
    while len(light.renders) < 1:
        assert job.step()
    job.cancel()
    job.stop()  # no work of the job runs any more
    assert job.state == "CANCELLED" and len(light.renders) == 1 and not light.decoded
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert not (tmp_path / "maps").exists()
