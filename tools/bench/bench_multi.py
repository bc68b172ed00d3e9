"""`python -m lapig_addon bench multi --json`: several projectors on one object in Cycles (issue 36).

Three setups, each captured by the add-on's sequence (lapig_core/multi/capture against the Cycles studio of
several projectors, blender/cycles_multi_device) and fitted by the first look (multi/first_look); every figure
below is a PSNR of *rendered* captures: the projector images are projected through the same studio and
captured with the exposure the capture locked.

- (a) bust: the demo statue, its projector swung 40 degrees to the camera's left, Add Projector's second one
  on the right (multi/placement); projectors 800x600 (the first look's timing), camera 320x240.
  coverage_single / coverage_joint, joint_gain_db (the joint compensation against the best single one's, on
  the whole camera-visible object), seam_ratio, refine_gain_db_multi (refine/joint), mpcdi_package.
- (b) wall: a 3.6 x 1.4 m textured wall, two projectors side by side (about 18 % overlap of each footprint).
  wall_vs_single_db (joint against each projector alone on its half), seam_ratio, white_uniformity_pct (the
  white through the blend's alpha maps, encoded with the blend probe's gammas (multi/blend_probe): overlap
  against each side; white_uniformity_pct_gamma_p: encoded with the joint fit's gamma_p, the old path).
- (c) stack: a dark textured panel (albedo x 0.3), two projectors at nearly one pose (3 cm apart).
  stack_psa_gain_db: PSA on the joint reach (multi/joint_psa via stylize_joint) rendered with both against one.

The look compensated on (a) is a smooth colour field placed within the joint reach (10 to 90 % of [I-, I+] of
both projectors together), the same for every projector count, so a single projector's unreached or dimmer
side counts against it; on (b) it is placed within each projector's own reach on its half, so one projector
per half can show it whole. Each key also gives the bound a perfect compensation reaches within the reach it
was given (the target clamped into [I-, I+]).
Writes benchmarks/bench_multi.json and JPEG sheets benchmarks/bench_multi_{bust,wall,stack}.jpg; the .mpcdi
stays in the output folder.
"""
from __future__ import annotations

import json
import math
import os
import time

import cv2
import numpy as np

CAMERA = (320, 240)
PROMPT = "Make it a stained glass artwork"
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BENCHMARKS = os.path.join(ROOT, "benchmarks")
FILL_BLURRED_BITS = True  # multi/graycode_fill; tools/research/multi_fill_compare.py turns it off for the old path


def _r(v, n=3):
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else round(float(v), n)


# ------------------------------------------------------------------ scenes
def _pose(obj, position, centre=None, rotation=None):
    from mathutils import Matrix

    from ...lapig_core.optics.placement import look_at

    m = np.eye(4)
    m[:3, :3] = look_at(position, centre).rotation if rotation is None else rotation
    m[:3, 3] = position
    obj.matrix_world = Matrix(m.tolist())


def _bust(folder, projector_size):
    import bpy

    from ...lapig_addon.blender import rig, scene_state
    from ...lapig_addon.cli import headless
    from ...lapig_core.multi.placement import _rotate_about

    scene, projector, camera, target = headless.build_demo_setup(
        "statue", "sakura", folder=folder, camera_resolution=CAMERA, projector_resolution=projector_size)
    centre = rig.object_centre(target)
    position = _rotate_about(np.array(projector.matrix_world.translation), centre, (0, 0, 1), -40.0)
    _pose(projector, position, centre)
    bpy.context.view_layer.update()
    rig.focus_on_object(projector, camera, target)
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}  # the placement rule: the other side
    bpy.context.view_layer.update()
    return scene, scene_state.rig_projectors(scene), camera, target


def _wall(folder, projector_size, width=3.6, height=1.4, footprint=0.55):
    """Two projectors side by side: each footprint `footprint` of the wall's width, flush with its sides, so
    each overlaps the other by (2 footprint - 1) / footprint of its own width (0.55: 18 %)."""
    import bpy

    from ...lapig_addon.blender import scene_state
    from ...lapig_addon.cli import headless

    scene, projector, camera, target = headless.build_demo_setup(
        "panel", "wood", folder=folder, camera_resolution=CAMERA, projector_resolution=projector_size,
        wall_size=(width, height))
    m = np.array(projector.matrix_world)
    pos, right, forward = m[:3, 3].copy(), m[:3, 0] / np.linalg.norm(m[:3, 0]), -m[:3, 2]
    centre = np.array(target.matrix_world.translation)
    distance = float((centre - pos) @ (forward / np.linalg.norm(forward)))
    projector.lapig_projector.throw_ratio = distance / (footprint * width)
    bpy.context.view_layer.update()
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    projectors = scene_state.rig_projectors(scene)
    shift = (width - footprint * width) / 2
    for p, side in zip(projectors, (-1, 1)):
        p.lapig_projector.throw_ratio = distance / (footprint * width)
        _pose(p, pos + side * shift * right, rotation=m[:3, :3])
    bpy.context.view_layer.update()
    return scene, projectors, camera, target, {"overlap_of_footprint": round((2 * footprint - 1) / footprint, 3),
                                               "throw_ratio": round(distance / (footprint * width), 3)}


def _stack(folder, projector_size, albedo=0.3):
    import bpy

    from ...lapig_addon.blender import scene_state
    from ...lapig_addon.cli import headless

    scene, projector, camera, target = headless.build_demo_setup(
        "panel", "sakura", folder=folder, camera_resolution=CAMERA, projector_resolution=projector_size,
        tint=(albedo, albedo, albedo))
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    projectors = scene_state.rig_projectors(scene)
    m = np.array(projectors[0].matrix_world)
    _pose(projectors[1], m[:3, 3] + 0.03 * m[:3, 1], rotation=m[:3, :3])  # 3 cm above: a stack
    bpy.context.view_layer.update()
    return scene, projectors, camera, target


# ------------------------------------------------------------------ capture and render
class Rig:
    """A captured rig of several projectors in the Cycles studio, kept open to render projector images."""

    def __init__(self, scene, projectors, camera, target, folder, name, train_count=6):
        from ...lapig_addon.blender.cycles_multi_device import CyclesMultiDevice
        from ...lapig_core.capture.settings import CaptureSettings
        from ...lapig_core.common.steps import run_to_end
        from ...lapig_core.multi.capture import run_multi_capture
        from ...lapig_core.multi.capture_set import load_multi_capture
        from ...lapig_core.multi.first_look import fit_joint_first_look

        self.names = tuple(p.name for p in projectors)
        self.device = CyclesMultiDevice(scene, projectors, camera, target, samples=1, ambient=0.03)
        self.device.__enter__()
        settings = CaptureSettings(out_dir=folder, setup_name=name, train_count=train_count, test_count=0,
                                   working_size=64)
        t0 = time.perf_counter()
        result = run_to_end(run_multi_capture(self.device, settings, self.names, fill_blurred_bits=FILL_BLURRED_BITS))
        ended = time.perf_counter()
        self.capture_s = ended - t0
        self.cs = load_multi_capture(result["setup_dir"])
        self.look = fit_joint_first_look(self.cs)
        self.first_look_s = time.perf_counter() - ended  # capture end -> first look, as CaptureJob counts for several
        self.model = self.look.model
        self.mask = self.cs.object_mask & self.model.reached.any(axis=0)
        self.object_mask = self.cs.object_mask
        # the object without its outline (2 px): silhouette pixels mix object and background in the camera
        inner = cv2.erode(self.object_mask.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        self.inner = inner & self.model.reached.any(axis=0)

    def single(self, k):
        from ...lapig_core.multi.joint_model import JointModel

        m = self.model
        return JointModel(m.gamma_c, (m.gamma_p[k],), m.M[k:k + 1], m.o, (m.maps[k],))

    def render(self, frames):
        """frames: one float [0,1] image (or None: black) per projector -> the capture, float [0,1]."""
        u8 = [None if f is None else np.round(np.clip(f, 0, 1) * 255).astype(np.uint8) for f in frames]
        shot = np.asarray(self.device.capture([u8])[0])
        return shot.astype(np.float32) / (255.0 if shot.dtype == np.uint8 else 1.0)

    def alone(self, k, frame):
        return self.render([frame if j == k else None for j in range(len(self.names))])

    def close(self):
        self.device.close()


def _look(shape, seed=5, lo=0.2, hi=0.65):
    """A smooth colour field (H,W,3), encoded lo..hi: the look every projector count is asked to show."""
    h, w = shape
    pattern = np.random.default_rng(seed).random((5, 7, 3)).astype(np.float32)
    pattern = cv2.resize(pattern, (w, h), interpolation=cv2.INTER_CUBIC).clip(0, 1)
    return (lo + (hi - lo) * pattern).astype(np.float32)


def _in_reach(pattern, lo, hi, low=0.1, high=0.9):
    """The pattern (encoded 0..1) placed within [lo, hi] per pixel: low..high of the range."""
    return (lo + (hi - lo) * (low + (high - low) * pattern)).astype(np.float32)


def _bound(model, target, mask):
    """The PSNR a perfect compensation reaches within `model`'s reach: the target clamped into [I-, I+]."""
    from ...lapig_core.multi.joint_solve import reach
    from .seams import psnr_on

    lo, hi = reach(model)
    return psnr_on(np.clip(target, lo, hi), target, mask)


def _sheet(path, tiles, title, columns=4):
    from ...lapig_core.common.sheets import labelled_grid

    grid = labelled_grid([t for t, _ in tiles], [lab for _, lab in tiles], columns=columns, cell=320, title=title)
    grid = np.asarray(grid)
    if grid.dtype != np.uint8:
        grid = np.round(np.clip(grid, 0, 1) * 255).astype(np.uint8)
    cv2.imwrite(path, cv2.cvtColor(grid, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 88])
    return os.path.relpath(path, ROOT)


def _error_share(capture, look, obj, inner, reached):
    """Where the squared error of a capture against the look lies on the object: shares of the whole
    object's, from the pixels no projector reaches, the reached outline (2 px) and the reached inside."""
    sq = ((capture - look) ** 2).mean(axis=-1)
    total = float(sq[obj].sum()) or 1.0
    parts = {"unreached": obj & ~reached, "outline_reached": obj & ~inner & reached, "inner_reached": inner & reached}
    return {name: {"share": _r(float(sq[m].sum()) / total, 3), "pixels": int(m.sum())} for name, m in parts.items()}


def _weights_colour(weights):
    colours = np.array([[1, 0.15, 0.15], [0.15, 1, 0.15], [0.2, 0.4, 1], [1, 1, 0.15]], np.float32)
    return np.einsum("khw,kc->hwc", weights, colours[:len(weights)]).clip(0, 1)


# ------------------------------------------------------------------ the three setups
def _run_bust(out, projector_size, refine_iterations):
    from ..checks.mpcdi_read import read_mpcdi
    from ...lapig_core.multi.blend import blend_weights
    from ...lapig_core.multi.joint_solve import joint_compensate
    from ...lapig_core.multi.mpcdi_export import write_rig_mpcdi
    from .seams import psnr_on, seam_ratio

    scene, projectors, camera, target = _bust(os.path.join(out, "scene_bust"), projector_size)
    rig = Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "bust")
    try:
        from ...lapig_core.multi.joint_solve import reach

        model, obj = rig.model, rig.object_mask
        look = _in_reach(_look(model.shape, lo=0.0, hi=1.0), *reach(model))  # what both together can show
        weights = blend_weights(model.maps)
        t = time.perf_counter()
        joint = joint_compensate(model, look, weights)
        solve_s = time.perf_counter() - t
        cap_joint = rig.render(joint.frames)
        res = {"projector_size": list(projector_size), "camera": list(CAMERA), "names": list(rig.names),
               "coverage_single": _r(rig.look.coverage_single, 4), "coverage_joint": _r(rig.look.coverage_joint, 4),
               "per_projector": [_r(v, 4) for v in rig.look.coverage.per_projector],
               "coverage_joint_inner": _r(rig.inner.sum() / max(1, cv2.erode(
                   obj.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool).sum()), 4),
               "black_uplift": rig.look.to_dict()["black_uplift"], "fit_residual": _r(model.residual, 4),
               "together_rms": _r(model.together_rms, 4), "capture_s": _r(rig.capture_s, 1),
               "first_look_seconds": _r(rig.first_look_s, 2), "joint_solve_s": _r(solve_s, 2),
               "psnr_joint": _r(psnr_on(cap_joint, look, obj)),
               "psnr_joint_simulated": _r(psnr_on(model.predict(joint.frames), look, obj)),
               "bound_joint": _r(_bound(model, look, obj))}
        singles, caps = [], []
        for k in range(len(projectors)):
            one = rig.single(k)
            comp = joint_compensate(one, look)
            cap = rig.alone(k, comp.frames[0])
            caps.append(cap)
            singles.append({"psnr": _r(psnr_on(cap, look, obj)), "bound": _r(_bound(one, look, obj))})
        best = int(np.argmax([s["psnr"] for s in singles]))
        res["singles"] = singles
        res["best_single"] = best + 1
        res["joint_gain_db"] = _r(res["psnr_joint"] - singles[best]["psnr"])
        # the headroom: the best single one's bound (the joint bound is infinite: the look lies in its reach)
        res["best_single_bound"] = singles[best]["bound"]
        err = np.abs(cap_joint - look)
        res["seam_ratio"] = _r(seam_ratio(err, model.reached, rig.mask))
        res["psnr_joint_on_reach"] = _r(psnr_on(cap_joint, look, rig.mask))
        res["seam_ratio_inner"] = _r(seam_ratio(err, model.reached, rig.inner))  # the outline left out
        inner_obj = cv2.erode(obj.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        res["psnr_joint_inner"] = _r(psnr_on(cap_joint, look, inner_obj))
        res["psnr_singles_inner"] = [_r(psnr_on(c, look, inner_obj)) for c in caps]
        res["error_share"] = _error_share(cap_joint, look, obj, inner_obj, model.reached.any(axis=0))
        res["joint_gain_db_inner"] = _r(res["psnr_joint_inner"] - max(res["psnr_singles_inner"]))
        # the MPCDI package, read back by the strict reader
        package = os.path.join(out, "bust.mpcdi")
        write_rig_mpcdi(package, model, rig.names, weights)
        read = read_mpcdi(package)
        res["mpcdi_package"] = os.path.abspath(package)
        res["mpcdi_check"] = {"buffers": [b.id for b in read.buffers],
                              "resolutions": [list(b.resolution) for b in read.buffers],
                              "bytes": os.path.getsize(package)}
        # refinement of both projectors on the studio
        try:
            from ...lapig_core.refine.joint import refine_gain_db_multi
            from ...lapig_core.refine.loop import RefineSettings
        except ImportError:
            res["refine_gain_db_multi"], res["refine_reason"] = None, "multi refinement not built"
        else:
            t = time.perf_counter()
            record, refinement = refine_gain_db_multi(model, rig.device, look, rig.mask,
                                                      RefineSettings(iterations=refine_iterations, max_repeats=2))
            d = record.to_dict()
            res["refine"] = {k: d.get(k) for k in ("open_loop_psnr", "refined_psnr", "noise_floor_psnr",
                                                   "iterations", "captures", "stopped")}
            res["refine"]["seconds"] = _r(time.perf_counter() - t, 1)
            res["refine_gain_db_multi"] = _r(d["gain_db"])
            refined = rig.render(refinement.images)
            # the same on the object without its outline (silhouette pixels mix object and background)
            record_in, _ = refine_gain_db_multi(model, rig.device, look, rig.inner,
                                                RefineSettings(iterations=refine_iterations, max_repeats=2))
            d_in = record_in.to_dict()
            res["refine_inner"] = {k: d_in.get(k) for k in ("open_loop_psnr", "refined_psnr", "iterations", "stopped")}
            res["refine_gain_db_multi_inner"] = _r(d_in["gain_db"])
            res["refine"]["refined_psnr_object"] = _r(psnr_on(refined, look, obj))
        tiles = [(look * obj[..., None], "asked look (object)"),
                 (cap_joint, f"joint, rendered {res['psnr_joint']:.1f} dB"),
                 (caps[0], f"proj. 1 alone {singles[0]['psnr']:.1f} dB"),
                 (caps[1], f"proj. 2 alone {singles[1]['psnr']:.1f} dB"),
                 (_weights_colour(weights), "blend weights (1 red, 2 green)"),
                 (np.clip(err * 4, 0, 1), f"joint error x4, seam ratio {res['seam_ratio']}"),
                 (rig.cs.together.astype(np.float32) / 255, "white, both (capture)"),
                 (cv2.resize(joint.frames[0], CAMERA, interpolation=cv2.INTER_AREA), "projector 1 image")]
        if "refine" in res:
            tiles.append((refined, f"refined {res['refine']['refined_psnr_object']} dB"))
        res["sheet"] = _sheet(os.path.join(BENCHMARKS, "bench_multi_bust.jpg"), tiles,
                              "(a) bust, two projectors front left / right: joint vs single, rendered in Cycles")
        return res
    finally:
        rig.close()


def _run_wall(out, projector_size):
    from ...lapig_core.multi.blend import alpha_maps, blend_weights, encode_alpha
    from ...lapig_core.multi.joint_solve import joint_compensate
    from .seams import psnr_on, seam_ratio, white_uniformity_pct

    scene, projectors, camera, target, layout = _wall(os.path.join(out, "scene_wall"), projector_size)
    rig = Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "wall")
    try:
        from ...lapig_core.multi.joint_solve import reach

        model, mask = rig.model, rig.mask
        weights = blend_weights(model.maps)
        halves = np.argmax(weights, axis=0)
        pattern = _look(model.shape, seed=7, lo=0.0, hi=1.0)
        ranges = [reach(rig.single(k)) for k in range(len(projectors))]
        lo = np.where((halves == 0)[..., None], ranges[0][0], ranges[1][0])
        hi = np.where((halves == 0)[..., None], ranges[0][1], ranges[1][1])
        look = _in_reach(pattern, lo, hi)  # what each projector alone can show on its half
        joint = joint_compensate(model, look, weights)
        cap_joint = rig.render(joint.frames)
        res = {"projector_size": list(projector_size), **layout,
               "coverage": {"per_projector": [_r(v, 4) for v in rig.look.coverage.per_projector],
                            "joint": _r(rig.look.coverage_joint, 4), "overlap": _r(rig.look.coverage.overlap, 4)},
               "psnr_joint": _r(psnr_on(cap_joint, look, mask)), "bound_joint": _r(_bound(model, look, mask))}
        # each projector alone on its half (where its blend weight is the larger): one projector per half
        sq, n, caps = 0.0, 0, []
        for k in range(len(projectors)):
            one = rig.single(k)
            cap = rig.alone(k, joint_compensate(one, look).frames[0])
            caps.append(cap)
            half = mask & (halves == k)
            d = (cap - look)[half]
            sq, n = sq + float((d * d).sum()), n + d.size
        res["psnr_halves_single"] = _r(10 * math.log10(1 / (sq / n)))
        halves_img = np.where((halves == 0)[..., None], caps[0], caps[1])
        res["wall_vs_single_db"] = _r(res["psnr_joint"] - res["psnr_halves_single"])
        err = np.abs(cap_joint - look)
        res["seam_ratio"] = _r(seam_ratio(err, model.reached, mask))
        res["seam_ratio_inner"] = _r(seam_ratio(err, model.reached, rig.inner))
        # white through the blend's alpha maps, and the plain white of both (no blend) for comparison
        # (the alpha maps encoded with the blend probe's gammas, as the MPCDI package and the Blend preview;
        # beside it the old path, encoded with the joint fit's gamma_p)
        alphas = alpha_maps(model.maps, weights)
        white_frames = [np.repeat(encode_alpha(a, g)[..., None], 3, axis=-1) for a, g in zip(alphas, model.alpha_gammas)]
        white = rig.render(white_frames)
        u = white_uniformity_pct(white, model.reached, mask, model.gamma_c)
        old_frames = [np.repeat(encode_alpha(a, g)[..., None], 3, axis=-1) for a, g in zip(alphas, model.gamma_p)]
        u_old = white_uniformity_pct(rig.render(old_frames), model.reached, mask, model.gamma_c)
        res["white_uniformity_pct_gamma_p"] = _r(u_old["pct"], 2)
        res["blend_gamma"] = rig.look.blend_fit.to_dict() if rig.look.blend_fit is not None else None
        res["gamma_p"] = [_r(g, 3) for g in model.gamma_p]
        res["gamma_c"] = _r(model.gamma_c, 3)
        plain = white_uniformity_pct(rig.cs.together.astype(np.float32) / 255, model.reached, mask, model.gamma_c)
        res["white_uniformity_pct"] = _r(u["pct"], 2)
        res["white_means_linear"] = {"overlap": _r(u["overlap"], 4), "sides": [_r(v, 4) for v in u["sides"]]}
        res["white_uniformity_pct_unblended"] = _r(plain["pct"], 2)
        band = max(4, int(round(0.05 * model.shape[1])))  # 5 % of the camera's width beside the overlap
        ua = white_uniformity_pct(white, model.reached, mask, model.gamma_c, adjacent_px=band)
        res["white_uniformity_pct_adjacent"] = _r(ua["pct"], 2)
        res["white_adjacent_px"] = band
        res["white_means_linear_adjacent"] = {"overlap": _r(ua["overlap"], 4), "sides": [_r(v, 4) for v in ua["sides"]]}
        # the same on the all-white captures of each projector alone weighted by the alphas (in camera space):
        # what the blend would show if it were exact; its non-uniformity is the wall's and the light's own
        alone = [rig.alone(k, np.ones(rig.cs.sizes[k][::-1] + (3,), np.float32)) for k in range(len(projectors))]
        ideal = sum(np.power(a, model.gamma_c) * w[..., None] for a, w in zip(alone, weights))
        ui = white_uniformity_pct(np.power(ideal, 1 / model.gamma_c), model.reached, mask, model.gamma_c)
        res["white_uniformity_pct_exact_blend"] = _r(ui["pct"], 2)
        # the blend's own error: the blended white over the exact blend per pixel (the wall's texture and the
        # light's fall-off divide out), overlap against each side
        ratio = np.power(np.clip(white, 1e-4, 1), model.gamma_c).mean(-1) / np.maximum(ideal.mean(-1), 1e-6)
        count = model.reached.sum(axis=0)
        over = float(np.median(ratio[mask & (count >= 2)]))
        sides = [float(np.median(ratio[mask & model.reached[k] & (count == 1)])) for k in range(len(projectors))]
        res["white_blend_ratio"] = {"overlap": _r(over, 4), "sides": [_r(v, 4) for v in sides]}
        res["white_uniformity_pct_albedo_normalised"] = _r(max(abs(over / v - 1) * 100 for v in sides), 2)
        # compensated flat white (the joint solve asked for an even grey): the texture taken out
        level = float(np.percentile(reach(model)[1][mask].min(-1), 2)) * 0.9  # within reach in every channel
        flat = np.full(model.shape + (3,), level, np.float32)
        res["flat_grey_level"] = _r(level)
        flat_cap = rig.render(joint_compensate(model, flat, weights).frames)
        uf = white_uniformity_pct(flat_cap, model.reached, mask, model.gamma_c)
        res["flat_grey_uniformity_pct"] = _r(uf["pct"], 2)
        tiles = [(look, "asked look"), (cap_joint, f"joint, rendered {res['psnr_joint']:.1f} dB"),
                 (halves_img, f"one projector per half {res['psnr_halves_single']:.1f} dB"),
                 (np.clip(err * 4, 0, 1), f"joint error x4, seam ratio {res['seam_ratio']}"),
                 (white, f"white through the alpha maps: {res['white_uniformity_pct']} %"),
                 (rig.cs.together.astype(np.float32) / 255, "white, both, no blend"),
                 (flat_cap, f"compensated even grey {level:.2f}: {res['flat_grey_uniformity_pct']} %"),
                 (_weights_colour(weights), "blend weights (1 red, 2 green)")]
        res["sheet"] = _sheet(os.path.join(BENCHMARKS, "bench_multi_wall.jpg"), tiles,
                              "(b) wide wall, two projectors side by side: rendered in Cycles")
        return res
    finally:
        rig.close()


def _run_stack(out, projector_size, backend, working_size):
    from .seams import psnr_on

    scene, projectors, camera, target = _stack(os.path.join(out, "scene_stack"), projector_size)
    rig = Rig(scene, projectors, camera, target, os.path.join(out, "captures"), "stack")
    try:
        model = rig.model
        one = rig.single(0)
        mask = rig.object_mask & one.reached.any(axis=0) & model.reached.any(axis=0)
        surface = rig.cs.together.astype(np.float32) / 255
        single_white = rig.alone(0, np.ones(rig.cs.sizes[0][::-1] + (3,), np.float32))
        res = {"projector_size": list(projector_size), "albedo": 0.3,
               "coverage": [_r(v, 4) for v in rig.look.coverage.per_projector],
               "white_gain_linear": _r(float(np.mean(np.power(surface[mask], model.gamma_c))) /
                                       max(float(np.mean(np.power(single_white[mask], model.gamma_c))), 1e-9))}
        try:
            from ...lapig_core.multi.joint_psa import simulated_psnr
            from ...lapig_core.multi.stylize import stylize_joint
        except ImportError:
            res["stack_psa_gain_db"], res["reason"] = None, "PSA on the joint reach not built"
            return res
        figures, tiles = {}, []
        for name, m, surf in (("stacked", model, surface), ("single", one, single_white)):
            t = time.perf_counter()
            look = stylize_joint(m, surf, PROMPT, backend, 0, working_size=working_size, object_mask=mask, psa=True,
                                 lgst_surface=surface)
            seconds = time.perf_counter() - t
            frames = list(look.frames) + [None] * (len(projectors) - len(look.frames))
            cap = rig.render(frames)
            frames_nopsa = list(look.without.frames) + [None] * (len(projectors) - len(look.frames))
            cap_nopsa = rig.render(frames_nopsa)
            figures[name] = {"psa_rendered": _r(psnr_on(cap, look.target, mask)),
                             "nopsa_rendered": _r(psnr_on(cap_nopsa, look.without.target, mask)),
                             "psa_simulated": _r(simulated_psnr(m, look, mask)),
                             "nopsa_simulated": _r(simulated_psnr(m, look.without, mask)),
                             "psa_look_vs_asked": _r(psnr_on(cap, look.without.target, mask)),
                             "stylize_s": _r(seconds, 1)}
            tiles += [(look.without.target, f"{name}: asked look"), (look.target, f"{name}: PSA look"),
                      (cap, f"{name}: PSA rendered {figures[name]['psa_rendered']} dB"),
                      (cap_nopsa, f"{name}: no PSA rendered {figures[name]['nopsa_rendered']} dB")]
        res["figures"] = figures
        res["prompt"], res["backend"] = PROMPT, backend
        res["stack_psa_gain_db"] = _r(figures["stacked"]["psa_rendered"] - figures["single"]["psa_rendered"])
        res["stack_psa_gain_db_simulated"] = _r(figures["stacked"]["psa_simulated"] -
                                                figures["single"]["psa_simulated"])
        res["stack_look_gain_db"] = _r(figures["stacked"]["psa_look_vs_asked"] -
                                       figures["single"]["psa_look_vs_asked"])
        tiles += [(surface, "white, both stacked"), (single_white, "white, one")]
        res["sheet"] = _sheet(os.path.join(BENCHMARKS, "bench_multi_stack.jpg"), tiles,
                              "(c) dark panel, two stacked projectors against one: PSA, rendered in Cycles")
        return res
    finally:
        rig.close()


def _demo_figures():
    """The one-projector demo's stored rendered PSNRs (benchmarks/demo_*.json, newest first)."""
    stored = {}
    for name in ("demo_after_merge_idle.json", "demo_issue28_session3_idle.json"):
        path = os.path.join(BENCHMARKS, name)
        if os.path.isfile(path):
            with open(path) as f:
                d = json.load(f)
            stored[name] = {k: d.get(k) for k in ("rendered_psnr", "rendered_psnr_nopsa", "rendered_psnr_native")}
    return stored


def run(args) -> dict:
    global CAMERA, BENCHMARKS
    out = os.path.abspath(args.out or "out/bench_multi")
    os.makedirs(out, exist_ok=True)
    big, small = (800, 600), (400, 300)
    if os.environ.get("LAPIG_BENCH_MULTI_TINY"):  # a smoke run of the code paths, written under --out only
        CAMERA, big, small, BENCHMARKS = (96, 72), (128, 96), (128, 96), out
    t0 = time.perf_counter()
    results = {}
    results["bust"] = _run_bust(out, big, refine_iterations=6)
    results["wall"] = _run_wall(out, small)
    results["stack"] = _run_stack(out, small, getattr(args, "backend", "styletransfer"), 128)
    bust, wall, stack = results["bust"], results["wall"], results["stack"]
    seams = [v for v in (bust["seam_ratio"], wall["seam_ratio"]) if v is not None]
    demo = _demo_figures()
    summary = {
        "coverage_single": bust["coverage_single"], "coverage_joint": bust["coverage_joint"],
        "joint_gain_db": bust["joint_gain_db"], "wall_vs_single_db": wall["wall_vs_single_db"],
        "seam_ratio": max(seams) if seams else None,
        "seam_ratio_bust": bust["seam_ratio"], "seam_ratio_wall": wall["seam_ratio"],
        "seam_ratio_inner": {"bust": bust["seam_ratio_inner"], "wall": wall["seam_ratio_inner"]},
        "joint_gain_db_inner": bust["joint_gain_db_inner"],
        "white_uniformity_pct": wall["white_uniformity_pct"],
        "white_uniformity_pct_gamma_p": wall["white_uniformity_pct_gamma_p"],
        "blend_gamma": wall["blend_gamma"],
        "white_uniformity_pct_adjacent": wall["white_uniformity_pct_adjacent"],
        "white_uniformity_pct_exact_blend": wall["white_uniformity_pct_exact_blend"],
        "coverage_joint_inner": bust["coverage_joint_inner"],
        "white_uniformity_pct_albedo_normalised": wall["white_uniformity_pct_albedo_normalised"],
        "refine_gain_db_multi_inner": bust.get("refine_gain_db_multi_inner"),
        "stack_psa_gain_db": stack.get("stack_psa_gain_db"),
        "refine_gain_db_multi": bust.get("refine_gain_db_multi"),
        "first_look_seconds_multi": bust["first_look_seconds"],
        "single_projector_unchanged": None,
        "single_projector_reason": "the demo was not run by this bench (minutes of training on a shared machine); "
                                   "its stored figures are in `demo_stored`; bench multi touches no one-projector "
                                   "path",
        "demo_stored": demo,
        "mpcdi_package": bust["mpcdi_package"],
        "setups": results,
        "total_s": round(time.perf_counter() - t0, 1),
        "note": "timings on a 2-core machine shared with other jobs",
    }
    if stack.get("stack_psa_gain_db") is None:
        summary["stack_psa_reason"] = stack.get("reason")
    from .machine_figure import machine_speed, with_machine_figures

    written = with_machine_figures(summary, machine_speed())
    os.makedirs(BENCHMARKS, exist_ok=True)
    with open(os.path.join(BENCHMARKS, "bench_multi.json"), "w") as f:
        json.dump(written, f, indent=1, default=str)
    return summary
