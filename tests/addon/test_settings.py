"""Scene settings plus explicit overrides (the command line's), and the generate request's checks."""
import pytest


@pytest.fixture
def scene_capture(state):
    """The Capture panel of a scene whose ambient light and gray level are not the defaults."""
    from lapig.lapig_core.capture.settings import CaptureSettings

    return CaptureSettings(out_dir="/data/Wall", setup_name="Wall", train_count=32, test_count=8,
                           working_size=256, gray_level=0.4, samples=1, ambient=0.12, seed=0,
                           pattern_folder=None, chunk=8)


def test_overrides_replace_what_is_given_and_keep_the_scene_for_the_rest(state, scene_capture):
    # as `capture --out DIR --train 2 --size 32`: the other arguments are None
    options = state.overridden(scene_capture, out_dir="/out", setup_name=None, train_count=2, test_count=None,
                               working_size=32, samples=None, pattern_folder=None, seed=None)
    assert (options.out_dir, options.setup_name, options.train_count, options.working_size) == ("/out", "Wall", 2, 32)
    assert options.ambient == 0.12 and options.gray_level == 0.4  # the scene's room and references
    assert options.test_count == 8 and options.pattern_folder is None
    assert scene_capture.train_count == 32  # the scene's own values are untouched
    with pytest.raises(TypeError):
        state.overridden(scene_capture, gray=0.5)  # a misspelt setting is an error, not ignored


def _request(state, **kw):
    return state.GenerateRequest(**{"prompt": "Make it a stained glass artwork", "backend": "styletransfer",
                                    "mix": "", "psa": True, "adaptation": 0.5, "seed": 0, **kw})


def test_generate_request_from_the_scene_and_the_command_line(state):
    scene = _request(state, backend="instruct-pix2pix", psa=False, seed=3)
    cli = state.overridden(scene, prompt="Render it as charcoal", backend=None, mix=None, psa=None, adaptation=0.3,
                           seed=None, ip2p_model=None)
    assert cli == _request(state, prompt="Render it as charcoal", backend="instruct-pix2pix", psa=False,
                           adaptation=0.3, seed=3)


@pytest.mark.parametrize("change, problem", [
    ({}, ""),
    ({"prompt": "   "}, "Type a prompt"),
    ({"prompt": "", "mix": "charcoal_wash:1"}, ""),
    ({"adaptation": 0.0}, ""),  # the panel's own range, both ends included (services/limits.py)
    ({"adaptation": 1.0}, ""),
    ({"adaptation": -0.1}, "Adaptation must be between 0.0 and 1.0, got -0.1"),
    ({"adaptation": 1.5}, "Adaptation must be between 0.0 and 1.0"),
    ({"seed": -1}, "Style seed must be at least 0, got -1"),
])
def test_generate_request_problems(state, change, problem):
    found = _request(state, **change).problem()
    assert (problem in found) if problem else found == ""


def test_only_instruct_pix2pix_gets_the_weights_folder(state):
    assert _request(state, backend="instruct-pix2pix", ip2p_model="/models/ip2p").backend_options() == \
        {"model": "/models/ip2p"}
    assert _request(state, backend="instruct-pix2pix").backend_options() == {}
    assert _request(state, ip2p_model="/models/ip2p").backend_options() == {}  # styletransfer takes no model


@pytest.mark.torch
def test_a_ready_depth_adapter_goes_to_instruct_pix2pix_and_asks_for_the_geometry(state, monkeypatch):
    pytest.importorskip("torch")  # Generate's job runs PSA
    from lapig.lapig_addon.services.generate import generate_job

    request = _request(state, backend="instruct-pix2pix", depth_model="/models/depth-adapter")
    assert request.backend_options() == {"depth_adapter": "/models/depth-adapter"}
    assert _request(state, depth_model="/models/depth-adapter").backend_options() == {}  # styletransfer: none
    assert _request(state, backend="one-step", one_step_model="/models/sd-turbo",
                    depth_model="/models/depth-adapter").backend_options() == {"model": "/models/sd-turbo"}

    class Store:
        def look_geometry(self, w, h):
            return ("the scene's geometry", w, h)

    monkeypatch.setattr(generate_job, "frame_size_of", lambda folder: (64, 48))
    look_geometry = generate_job.look_geometry
    assert look_geometry(Store(), "/capture", "instruct-pix2pix", "", "a prompt", depth=True) == \
        ("the scene's geometry", 64, 48)
    assert look_geometry(Store(), "/capture", "instruct-pix2pix", "", "a prompt") is None  # no adapter: no rays
    assert look_geometry(object(), "/capture", "instruct-pix2pix", "", "a prompt", depth=True) == "capture"


def test_export_settings_overrides(state):
    scene = state.ExportSettings(path="/blend/projector_image.png", bit_depth=8, crossfade_frames=60)
    assert state.overridden(scene, path="/out/p.png", bit_depth=16, crossfade_frames=None) == \
        state.ExportSettings(path="/out/p.png", bit_depth=16, crossfade_frames=60)


def test_camera_response_uses_the_manual_exposure_unless_given(state):
    camera = state.CameraSettings(width=480, height=360, auto_exposure=False, exposure=-1.5, response_gamma=2.0,
                                  noise=0.01)
    assert camera.response().exposure_stops == -1.5
    response = camera.response(0.75)
    assert (response.exposure_stops, response.gamma, response.noise_std) == (0.75, 2.0, 0.01)


def test_a_style_image_needs_no_prompt_and_picks_the_reference_image_backend(state, tmp_path):
    image = tmp_path / "painting.png"
    image.write_bytes(b"not checked here: problem() only sees that it is a file")
    request = _request(state, prompt="", style_images=(str(image),), style_prompt_weight=0.25)
    assert request.problem() == ""
    assert request.lgst_backend() == "arbitrary" and request.backend == "styletransfer"
    assert request.backend_options() == {"style_images": (str(image),), "prompt_weight": 0.25}
    assert _request(state).lgst_backend() == "styletransfer" and _request(state).backend_options() == {}


def test_style_image_problems(state, tmp_path):
    missing = _request(state, style_images=(str(tmp_path / "gone.jpg"),)).problem()
    assert missing == f"style image not found: {tmp_path / 'gone.jpg'}"
    assert "is a folder" in _request(state, style_images=(str(tmp_path),)).problem()
    weighted = tmp_path / "a.png"
    weighted.write_bytes(b"x")
    assert _request(state, style_images=(f"{weighted}:0.5",)).problem() == ""
    assert "Prompt share" in _request(state, style_images=(str(weighted),), style_prompt_weight=1.5).problem()
