"""Realistic light transport in Cycles captures, at small sizes: bounce light, defocus, the user's
gloss and subsurface materials, and the mode in the capture's fingerprint."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.blender

WHITE = np.full((120, 160, 3), 235, np.uint8)


def _setup(tmp_path, shape, finish="matte", surface="sakura", camera=(96, 72)):
    from lapig.lapig_addon.blender import rig
    from lapig.lapig_addon.cli import headless

    scene, projector, camera_obj, target = headless.build_demo_setup(shape, surface, folder=str(tmp_path),
                                                                     camera_resolution=camera, finish=finish)
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = 160, 120
    rig.add_rig(bpy.context, target, projector, camera_obj)
    camera_obj.lapig_camera.noise = 0.0  # compare light, not sensor noise
    camera_obj.lapig_camera.auto_exposure = False
    return scene, projector, camera_obj, target


def _linear(setup, transport, frames, ambient=0.0):
    """Linear renders (what the camera's response then encodes) of native frames."""
    from lapig.lapig_addon.blender.cycles_device import CyclesCaptureDevice

    with CyclesCaptureDevice(*setup, transport=transport, ambient=ambient) as device:
        return device._linear(frames)


def _realistic(**kw):
    from lapig.lapig_core.optics.transport import LightTransport

    base = dict(projector_lens_radius_mm=0.0, vignetting=0.0, indirect_samples=16)
    return LightTransport(**{**base, **kw})


def test_the_light_transport_mode_is_in_the_fingerprint_and_a_change_says_why_the_capture_is_stale(
        lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state

    scene, projector, camera, target = _setup(tmp_path, "panel")
    state = scene_state.read(scene)
    assert state.rig.transport.startswith("Realistic")
    folder = tmp_path / "capture"
    folder.mkdir()
    scene_state.record_capture(scene, str(folder), state.rig.fingerprint, state.rig.transport)
    assert panel_state.capture_status(scene_state.read(scene)).state == "DONE"
    projector.lapig_projector.transport_mode = "FAST"
    now = scene_state.read(scene)
    assert now.rig.fingerprint != state.rig.fingerprint
    status = panel_state.capture_status(now)
    assert status.state == "STALE"
    assert "Captured in Realistic" in status.text and "now Fast" in status.text
    assert panel_state.capture_blocker(now) == "The light transport changed: capture again"
    projector.lapig_projector.transport_mode = "REALISTIC"
    projector.lapig_projector.focus_distance += 0.5  # a lens setting is part of it too
    assert scene_state.read(scene).rig.fingerprint != state.rig.fingerprint


def test_a_concave_corner_shows_the_light_it_bounces_onto_itself(lapig_registered, tmp_path):
    from lapig.lapig_core.optics.transport import FAST

    corner = _setup(tmp_path, "corner")
    direct, realistic = (_linear(corner, t, [WHITE])[0] for t in (FAST, _realistic()))
    lit = direct.max(-1) > 1e-4
    bounce = (realistic - direct)[lit].mean() / direct[lit].mean()
    panel = _setup(tmp_path, "panel")
    p_direct, p_real = (_linear(panel, t, [WHITE])[0] for t in (FAST, _realistic()))
    p_lit = p_direct.max(-1) > 1e-4
    flat_bounce = (p_real - p_direct)[p_lit].mean() / p_direct[p_lit].mean()
    assert bounce > 0.05  # walls at 90 degrees light each other
    assert flat_bounce < 0.2 * bounce  # a flat wall has nothing to bounce light onto
    # and a dark square next to the corner gets light from the lit wall across it
    assert (realistic - direct)[lit].min() > -0.02 * direct[lit].mean()


def test_projector_defocus_blurs_off_the_focal_plane_and_keeps_it_sharp(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import rig
    from lapig.lapig_core.optics.transport import FAST

    setup = _setup(tmp_path, "panel", surface="sakura")
    scene, projector, camera, target = setup
    # turn the panel 55 degrees about its vertical axis: its two sides lie in front of and behind the focus
    target.rotation_euler.z = math.radians(55)
    bpy.context.view_layer.update()
    rig.focus_on_object(projector, camera, target)
    stripes = np.repeat(((np.arange(120) // 2) % 2 * 255).astype(np.uint8)[:, None], 160, 1)[..., None].repeat(3, -1)
    sharp, blurred = (_linear(setup, t, [stripes])[0].mean(-1)
                      for t in (FAST, _realistic(bounces=0, projector_lens_radius_mm=60.0)))
    lit = sharp > 1e-4
    cols = np.flatnonzero(lit.any(0))
    left, right = cols[: len(cols) // 5], cols[-len(cols) // 5:]
    middle = cols[len(cols) * 2 // 5: len(cols) * 3 // 5]

    def detail(im, c):
        d = np.abs(np.diff(im[:, c], axis=0))
        m = lit[1:, c] & lit[:-1, c]
        return d[m].mean()

    keep = {name: detail(blurred, c) / detail(sharp, c) for name, c in
            (("left", left), ("middle", middle), ("right", right))}
    assert keep["middle"] > 0.7, keep  # the focal plane stays sharp
    assert min(keep["left"], keep["right"]) < 0.5 * keep["middle"], keep  # off it, the stripes blur


def test_gloss_and_subsurface_materials_survive_in_the_capture(lapig_registered, tmp_path):
    from lapig.lapig_core.optics.transport import FAST

    transport = _realistic(bounces=2)
    peaks = {}
    for finish in ("matte", "glazed"):
        linear = _linear(_setup(tmp_path, "vase", finish=finish, surface="clouds"), transport, [WHITE])[0].max(-1)
        on = linear[linear > 1e-4]
        peaks[finish] = np.percentile(on, 99.9) / np.median(on)
    assert peaks["glazed"] > 1.5 * peaks["matte"], peaks  # the projector's highlight on the glaze

    # a thin lit line on a marble panel: light enters and leaves the stone beside it
    line = np.zeros((120, 160, 3), np.uint8)
    line[:, 78:82] = 255
    rows = {}
    for finish in ("matte", "marble"):
        setup = _setup(tmp_path, "panel", finish=finish, surface="sakura", camera=(160, 120))
        for name, t in (("fast", FAST), ("realistic", transport)):
            rows[finish, name] = _linear(setup, t, [line])[0].mean(-1)[30:90].mean(0)
    matte = rows["matte", "fast"]
    on_line = np.flatnonzero(matte > 0.1 * matte.max())
    beside = np.setdiff1d(np.arange(on_line.min() - 5, on_line.max() + 6), on_line)
    spread = {k: float(r[beside].mean() / r[on_line].mean()) for k, r in rows.items()}
    assert spread["marble", "realistic"] > 5 * spread["matte", "realistic"], spread
    assert spread["marble", "fast"] > 5 * spread["matte", "fast"], spread  # even direct light keeps it


def test_the_bounce_light_carries_the_texture_of_the_wall_it_falls_on(lapig_registered, tmp_path):
    """One wall lit, the other lit only by its bounce: the bounce light on the dark wall shows that
    wall's texture (the 'passes' method: irradiance times the full-size albedo), which the difference of
    two low-resolution renders smooths away."""
    import cv2

    from lapig.lapig_core.optics.transport import FAST

    corner = _setup(tmp_path, "corner", surface="wood", camera=(160, 120))
    white = _linear(corner, FAST, [WHITE])[0].mean(-1)
    half = WHITE.copy()
    half[:, 80:] = 0
    direct = _linear(corner, FAST, [half])[0].mean(-1)
    bounce = {method == "passes": _linear(corner, _realistic(bounces=2, bounce_method=method), [half])[0].mean(-1)
              - direct for method in ("passes", "difference")}
    dark_wall = (white > 1e-4) & (direct < 0.05 * white)  # (a few speckles of stray direct light)
    dark_wall = cv2.erode(dark_wall.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    assert dark_wall.sum() > 500

    on = (white > 1e-4).astype(np.float32)

    def texture(im):  # detail at a few pixels: the image over its own blur on the object, in log
        im = np.log(np.maximum(im, 1e-6)) * on
        return im - cv2.GaussianBlur(im, (0, 0), 3.0) / np.maximum(cv2.GaussianBlur(on, (0, 0), 3.0), 1e-6)

    corr = {g: float(np.corrcoef(texture(b)[dark_wall], texture(white)[dark_wall])[0, 1]) for g, b in bounce.items()}
    assert corr[True] > 0.6, corr
    assert corr[False] < corr[True] - 0.3, corr
    assert bounce[True][dark_wall].mean() == pytest.approx(bounce[False][dark_wall].mean(), rel=0.15)
