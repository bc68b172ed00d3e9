"""What each step shows and what blocks it, from plain scene states."""
import pytest


@pytest.fixture
def rig(state):
    return state.Rig(projector="Projector", camera="Camera", target="Wall", scene="Scene", fingerprint="rig-1")


@pytest.fixture
def captured(state, rig):
    """A scene captured with the rig as it is now."""
    return state.SceneState(rig=rig, capture_dir="/data/Wall/setups/Wall", capture_fingerprint="rig-1")


@pytest.fixture
def with_torch(panel_state, monkeypatch):
    monkeypatch.setattr(panel_state, "missing_required", lambda: [])


def test_a_changed_light_transport_makes_the_capture_stale_and_says_so(state, panel_state):
    def scene(rig_fp, rig_mode):
        rig = state.Rig(projector="Projector", camera="Camera", target="Wall", scene="Scene", fingerprint=rig_fp,
                        transport=rig_mode)
        return state.SceneState(rig=rig, capture_dir="/data/Wall", capture_fingerprint="rig-1",
                                capture_transport="Fast (direct light, pinhole lenses)")
    stale = scene("rig-2", "Realistic (3 bounces)")
    status = panel_state.capture_status(stale)
    assert status.state == "STALE"
    assert status.text == "Captured in Fast (direct light, pinhole lenses); the rig is now Realistic (3 bounces)"
    assert panel_state.capture_blocker(stale) == "The light transport changed: capture again"
    moved = scene("rig-2", "Fast (direct light, pinhole lenses)")  # same mode, the rig moved
    assert panel_state.capture_status(moved).text == "The rig or the object changed since the capture"
    assert panel_state.capture_status(scene("rig-1", "Fast (direct light, pinhole lenses)")).state == "DONE"


def test_a_changed_projector_resolution_makes_the_capture_stale_and_says_so(state, panel_state):
    def scene(rig_fp, size):
        rig = state.Rig(projector="Projector", camera="Camera", target="Wall", scene="Scene", fingerprint=rig_fp,
                        projector_size=size)
        return state.SceneState(rig=rig, capture_dir="/data/Wall", capture_fingerprint="rig-1",
                                capture_projector_size=(800, 600))
    stale = scene("rig-2", (1920, 1080))
    assert panel_state.capture_status(stale).text == "Captured for a 800x600 projector; it is now 1920x1080"
    assert panel_state.capture_blocker(stale) == "The projector's resolution changed: capture again"
    assert panel_state.capture_status(scene("rig-2", (800, 600))).text == \
        "The rig or the object changed since the capture"  # same resolution: something else changed
    assert panel_state.capture_status(scene("rig-1", (800, 600))).state == "DONE"


def test_rig_blockers(state, panel_state, rig):
    assert panel_state.rig_blocker(state.Rig()) == "Add the projector and camera first"
    assert panel_state.rig_blocker(state.Rig(projector="Projector", target="Wall")) == \
        "Add the projector and camera first"
    assert "surface object" in panel_state.rig_blocker(state.Rig(projector="Projector", camera="Camera"))
    outside = state.Rig(projector="Projector", camera="Camera", target="Wall", scene="Scene",
                        outside_scene=("Wall",))
    assert panel_state.rig_blocker(outside) == "'Wall' is not in the scene 'Scene'"
    assert panel_state.rig_blocker(rig) == ""


def test_capture_missing_done_and_stale_after_the_rig_moved(state, panel_state, rig, captured):
    missing = state.SceneState(rig=rig)
    assert panel_state.capture_status(missing) == panel_state.StepStatus("MISSING", "No capture yet")
    assert panel_state.capture_blocker(missing) == "Capture the surface first"
    assert panel_state.capture_status(captured) == panel_state.StepStatus("DONE", captured.capture_dir)
    assert panel_state.capture_blocker(captured) == ""
    moved = state.SceneState(rig=state.Rig(projector="Projector", camera="Camera", target="Wall",
                                           fingerprint="rig-2"),
                             capture_dir=captured.capture_dir, capture_fingerprint="rig-1")
    assert panel_state.capture_status(moved).state == "STALE"
    assert panel_state.capture_blocker(moved) == "The rig or the object moved: capture again"


def test_imported_capture_is_never_stale_but_still_needs_a_rig(state, panel_state, rig):
    imported = state.SceneState(rig=rig, capture_dir="/elsewhere/setups/real", capture_fingerprint="")
    assert panel_state.capture_status(imported).state == "DONE"
    no_rig = state.SceneState(capture_dir="/elsewhere/setups/real")
    assert panel_state.capture_status(no_rig).state == "DONE"
    assert panel_state.capture_blocker(no_rig) == "Add the projector and camera first"


def test_models_missing_stale_done(state, panel_state, captured):
    assert panel_state.models_status(captured).state == "MISSING"
    older = state.SceneState(rig=captured.rig, capture_dir=captured.capture_dir, capture_fingerprint="rig-1",
                             models_fingerprint="rig-0")
    assert panel_state.models_status(older) == panel_state.StepStatus("STALE", "Trained for an older capture")
    trained = state.SceneState(rig=captured.rig, capture_dir=captured.capture_dir, capture_fingerprint="rig-1",
                               models_fingerprint="rig-1", models_status="Fine-tuned in 41 s")
    assert panel_state.models_status(trained) == panel_state.StepStatus("DONE", "Fine-tuned in 41 s")


def test_models_wait_for_torch_then_for_the_capture(state, panel_state, captured, rig, monkeypatch):
    monkeypatch.setattr(panel_state, "missing_required", lambda: [type("Dep", (), {"package": "torch"})()])
    assert panel_state.models_blocker(captured) == "Install torch (see the add-on preferences)"
    monkeypatch.setattr(panel_state, "missing_required", lambda: [])
    assert panel_state.models_blocker(state.SceneState(rig=rig)) == "Capture the surface first"
    assert panel_state.models_blocker(captured) == ""


def _request(state, **kw):
    return state.GenerateRequest(**{"prompt": "Make it a stained glass artwork", "backend": "styletransfer",
                                    "mix": "", "psa": True, "adaptation": 0.5, "seed": 0, **kw})


def test_generate_waits_for_the_capture_then_for_a_prompt(state, panel_state, captured, with_torch):
    assert panel_state.generate_blocker(state.SceneState(), _request(state)) == "Add the projector and camera first"
    assert panel_state.generate_blocker(captured, _request(state, prompt="  ")) == "Type a prompt"
    assert panel_state.generate_blocker(captured, _request(state, prompt="", mix="charcoal_wash:1")) == ""
    assert panel_state.generate_blocker(captured, _request(state)) == ""


def test_result_missing_done_and_stale_after_the_rig_moved(state, panel_state, rig):
    assert panel_state.result_status(state.SceneState(rig=rig)).state == "MISSING"
    assert panel_state.result_blocker(state.SceneState(rig=rig)) == "Generate a projector image first"
    done = state.SceneState(rig=rig, result_dir="/data/results/20260101_120000_stained_glass",
                            result_fingerprint="rig-1")
    assert panel_state.result_status(done) == panel_state.StepStatus("DONE", "20260101_120000_stained_glass")
    assert panel_state.result_blocker(done) == ""
    moved = state.SceneState(rig=state.Rig(projector="Projector", camera="Camera", target="Wall",
                                           fingerprint="rig-2"),
                             result_dir=done.result_dir, result_fingerprint="rig-1")
    assert panel_state.result_status(moved) == panel_state.StepStatus("STALE", "The rig moved since this result")


def test_preview_modes_need_a_rig_and_the_result_views_a_result(state, panel_state, rig):
    no_result = state.SceneState(rig=rig)
    assert panel_state.preview_blocker(no_result, "ORIGINAL") == ""
    assert panel_state.preview_blocker(no_result, "PROJECTION") == ""
    assert panel_state.preview_blocker(no_result, "TARGET") == "Generate a projector image first"
    assert panel_state.preview_blocker(state.SceneState(), "ORIGINAL") == "Add the projector and camera first"


def test_capture_waits_for_numpy_and_opencv_not_for_torch(state, panel_state, captured, monkeypatch):
    dep = lambda package: type("Dep", (), {"package": package})()  # noqa: E731
    monkeypatch.setattr(panel_state, "missing_required", lambda: [dep("torch")])
    assert panel_state.capture_deps_blocker() == ""  # the classical first look is fitted without torch
    assert panel_state.capture_button_blocker(captured) == ""
    assert panel_state.torch_blocker() == "Install torch (see the add-on preferences)"
    monkeypatch.setattr(panel_state, "missing_required", lambda: [dep("opencv-contrib-python-headless"), dep("torch")])
    assert panel_state.capture_button_blocker(captured) == \
        "Install opencv-contrib-python-headless (see the add-on preferences)"
    monkeypatch.setattr(panel_state, "missing_required", lambda: [])
    assert panel_state.capture_button_blocker(state.SceneState(rig=state.Rig())) == "Add the projector and camera first"


def test_train_says_an_install_runs_then_to_restart_where_this_session_cannot_use_it(panel_state, monkeypatch):
    from lapig.lapig_addon.services.install.torch_install import SLOT, InstallOutcome

    dep = type("Dep", (), {"package": "torch"})()
    monkeypatch.setattr(panel_state, "missing_required", lambda: [dep])
    monkeypatch.setattr(SLOT, "job", type("Running", (), {"finished": False, "progress": 0.4})())
    assert panel_state.torch_blocker() == "Installing torch: 40% (the add-on preferences show it)"
    monkeypatch.setattr(SLOT, "job", None)
    monkeypatch.setattr(SLOT, "outcome", InstallOutcome("2.13.0", "CPU", active=False, why_restart="imported"))
    monkeypatch.setattr(panel_state, "missing_required", lambda: [])  # on disk now, but not in this session
    assert panel_state.torch_blocker() == "Restart Blender to use the torch just installed"
    monkeypatch.setattr(SLOT, "outcome", InstallOutcome("2.13.0", "CPU", active=True))
    assert panel_state.torch_blocker() == ""
