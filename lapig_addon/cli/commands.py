"""Implementations of the CLI commands (bpy work happens here, on the main thread)."""
from __future__ import annotations

import os
import shutil
import time

import bpy
import numpy as np

from ...lapig_core.capture import dataset as ds
from ...lapig_core.common.imageio import read_image, write_png
from ...lapig_core.common.sheets import labelled_grid
from ..blender import addon, result_preview, scene_state, storage
from ..blender.operator_boundary import refuse
from ..blender.scene_store import BlenderSceneStore, scene_seams
from ..services.errors import one_line
from ..services.panel.panel_state import rig_blocker
from . import headless, rig_choice
from .output import print_json, print_notes


def _ensure_registered():
    if not addon.is_registered():
        addon.register()


def cmd_demo(args) -> int:
    """The README's main job: demo scene -> capture -> models -> prompt -> projector image -> render."""
    from ...lapig_core.lgst.not_understood import check_prompt
    from ..services.export import export_result
    from ..services.generate.generate_job import GenerateJob, result_notes
    from ..services.train.train_job import TrainModelsJob
    from ..services.render.render_job import RenderResultJob

    check_prompt(args.prompt)  # now, not after minutes of capture and training (nothing understood: refused)
    _ensure_registered()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    timings = {}
    scene, projector, camera, target = headless.build_demo_setup(args.shape, args.surface, folder=out,
                                                                 seed=args.seed)
    blend_path = os.path.join(out, "demo.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend_path)  # data then lives beside it, in demo_lapig/
    scene = bpy.context.scene
    settings = scene_state.capture_settings(scene, train_count=args.train, test_count=args.test, seed=args.seed)
    t = time.perf_counter()
    result = headless.run_capture(scene, settings, progress=headless.print_progress)  # recorded in the scene
    timings["capture_s"] = round(time.perf_counter() - t, 2)
    write_png(os.path.join(out, "contact_sheet.png"), contact_sheet(result["setup_dir"]))
    t = time.perf_counter()
    seams = scene_seams(scene)
    trained = TrainModelsJob(seams, args.iterations, device=args.device).run_to_completion(
        on_progress=headless.print_progress)
    timings["train_s"] = round(time.perf_counter() - t, 2)
    request = scene_state.generate_request(scene, prompt=args.prompt)
    scene_state.write_stylize_settings(scene, request)  # demo.blend then opens on the prompt of its result
    t = time.perf_counter()
    generated = GenerateJob(seams, request, args.iterations, device=args.device).run_to_completion(
        on_progress=headless.print_progress)
    timings["stylize_s"] = round(time.perf_counter() - t, 2)
    print_notes(result_notes(generated["summary"]))
    t = time.perf_counter()
    rendered = RenderResultJob(seams).run_to_completion()
    timings["render_s"] = round(time.perf_counter() - t, 2)
    exported = export_result.export_current(
        seams.store, scene_state.export_settings(scene, path=os.path.join(out, "projector_image.png")))
    if result_preview.apply_mode(scene, "TARGET"):
        scene_state.record_preview_mode(scene, "TARGET")
    bpy.ops.wm.save_mainfile()
    sheet_path = os.path.join(out, "comparison.png")
    shutil.copyfile(os.path.join(generated["folder"], "comparison.png"), sheet_path)
    meta = result["meta"]
    m = rendered["metrics"]
    timings["total_s"] = round(time.perf_counter() - t0, 2)
    summary = {"comparison_sheet": sheet_path, "contact_sheet": os.path.join(out, "contact_sheet.png"),
               "projector_image": str(exported["image"]), "blend": blend_path, "result": generated["folder"],
               "prompt": args.prompt, "styles": generated["summary"]["lgst"].get("styles"),
               "understood": generated["summary"]["lgst"].get("understood"),
               "rendered_psnr": round(m.get("rendered_psnr", float("nan")), 3),
               "rendered_psnr_nopsa": round(m.get("rendered_psnr_nopsa", float("nan")), 3),
               "native_output": generated["summary"]["native_output"],
               "rendered_psnr_native": round(m.get("rendered_psnr_native", float("nan")), 3),
               "registration_error_px_median": meta["registration"].get("registration_error_px_median"),
               "train_device": trained["device"], "device": generated["summary"].get("device"), **timings,
               "train_phases_s": trained["phases"].rounded(), "train_threads": trained.get("threads", {})}
    print(f"Look at {sheet_path} and {summary['contact_sheet']}; open {blend_path} in Blender")
    print_json(summary)
    return 0


def contact_sheet(setup_dir) -> np.ndarray:
    """Raw and registered references, a few Gray-code captures, and training pairs."""
    layout = ds.DatasetLayout(os.path.dirname(os.path.dirname(setup_dir)), os.path.basename(setup_dir))
    refs = list(enumerate(["I- (black)", "I+ (white)", "s (gray)"], start=1))
    cells = [(layout.cam_raw_dir("ref"), i, f"raw {name}") for i, name in refs]  # (folder, image, label)
    cells += [(layout.cam_warp_dir("ref"), i, f"registered {name}") for i, name in refs]
    cells += [(layout.cam_raw_dir("sl"), i, f"Gray code {i}") for i in (1, 7, 15)]
    for i in (1, 2, 3):
        cells += [(layout.prj_dir("train"), i, f"projected train {i}"),
                  (layout.cam_raw_dir("train"), i, f"raw capture {i}"),
                  (layout.cam_warp_dir("train"), i, f"registered capture {i}")]
    images = [read_image(layout.image_path(folder, i)) for folder, i, _ in cells]
    return labelled_grid(images, [label for *_, label in cells], columns=6, cell=220,
                         title=f"LAPIG capture set: {layout.setup}")


def _open_scene(args):
    """The scene of --blend (else the open file), checked to hold a complete rig."""
    _ensure_registered()
    if args.blend:
        if not os.path.isfile(args.blend):
            raise ValueError(f"no such .blend file: {args.blend}")
        try:
            bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.blend))
        except RuntimeError as exc:  # empty, damaged or not a .blend at all
            raise ValueError(f"cannot open {args.blend}: it is empty, damaged or not a .blend file "
                             f"({one_line(exc)})") from exc
    scene = bpy.context.scene
    blocker = rig_blocker(scene_state.read_rig(scene))
    if blocker:
        raise ValueError(f"{blocker} (or run 'demo')")
    return scene


def cmd_capture(args) -> int:
    scene = _open_scene(args)
    settings = scene_state.capture_settings(
        scene, out_dir=os.path.abspath(args.out) if args.out else None, setup_name=args.setup,
        train_count=args.train, test_count=args.test, working_size=args.size, samples=args.samples,
        pattern_folder=os.path.abspath(args.patterns) if args.patterns else None, seed=args.seed)
    if args.save and not bpy.data.filepath:  # now, not after the capture
        raise ValueError("--save needs a .blend opened with --blend")
    devices = rig_choice.apply(args, scene)
    result = headless.run_capture(scene, settings, progress=headless.print_progress,
                                  devices=devices)  # recorded in the scene
    _save_if_asked(args)
    if not args.save:
        print_notes([f"this capture is not saved into the .blend (no --save): train it with "
                     f"'train --capture {result['setup_dir']}'"])
    meta = result["meta"]
    if "multi" in meta:  # several projectors: their coverage and the first look's figures
        print_json({"setup_dir": str(result["setup_dir"]), "projectors": meta["multi"]["projectors"],
                    "coverage": meta["coverage"], "first_look": result.get("first_look"),
                    "first_look_seconds": result.get("first_look_seconds"),
                    **({"first_look_error": result["first_look_error"]} if "first_look_error" in result else {}),
                    "rig": meta["rig"]["name"], "timings": meta["timings"]})
        return 0
    print_json({"setup_dir": str(result["setup_dir"]), **meta["registration"],
                "valid_fraction": meta["valid_fraction"], "rig": meta["rig"]["name"],
                **({"sync": meta["sync"]} if "sync" in meta else {})})
    return 0


def _save_if_asked(args):
    if args.save:
        if not bpy.data.filepath:
            raise ValueError("--save needs a .blend opened with --blend")
        bpy.ops.wm.save_mainfile()


def cmd_train(args) -> int:
    from ..services.train.train_job import TrainModelsJob

    scene = _open_scene(args)
    devices = rig_choice.apply(args, scene)
    capture = _chosen_capture(args, BlenderSceneStore(scene))
    out = TrainModelsJob(scene_seams(scene, devices=devices), _iterations(args, scene), capture,
                         device=args.device).run_to_completion(on_progress=headless.print_progress)
    _save_if_asked(args)
    print_json({"capture": out["folder"], "train_s": round(out["seconds"], 2), "compensation": out["choice"],
                "device": out["device"], "phases_s": out["phases"].rounded(), "threads": out.get("threads", {})})
    return 0


def _style_image_specs(specs) -> tuple | None:
    """--style-image values with absolute paths (a weight kept), None when none was given (the scene's)."""
    if not specs:
        return None
    from ...lapig_core.common.style_image import parse_style_image_spec

    from ..services.generate.generate_job import check_style_images

    out = []
    for spec in specs:
        path, weight = parse_style_image_spec(spec)
        out.append(os.path.abspath(path) + (f":{weight:g}" if weight != 1.0 else ""))
    check_style_images(out)
    return tuple(out)


def cmd_stylize(args) -> int:
    """stylize: the look and its compensation (one projector: by its models; several: the joint look, PSA on their
    joint reach, and compensation), then --refine N: the projector image(s) refined on the rig (several: all
    together); --render: the image(s), refined where they were, shown at once and captured, their figures in the
    JSON."""
    from ..services.generate.generate_job import GenerateJob, result_notes
    from ..services.render.render_job import RenderResultJob

    style_images = _style_image_specs(args.style_images)  # a bad image is refused before the .blend opens
    prompt = args.prompt if args.prompt is not None else ("" if style_images else None)
    if prompt is None:
        raise ValueError("stylize needs --prompt (or --style-image)")
    scene = _open_scene(args)
    seams = scene_seams(scene, devices=rig_choice.apply(args, scene))
    capture = _chosen_capture(args, seams.store)
    request = scene_state.generate_request(scene, prompt=prompt, backend=args.backend, mix=args.mix,
                                           psa=args.psa, adaptation=args.adaptation, seed=args.seed,
                                           ip2p_model=args.ip2p_model, style_images=style_images,
                                           depth_model=getattr(args, "depth_model", None),
                                           one_step_model=getattr(args, "one_step_model", None),
                                           style_prompt_weight=args.style_prompt_weight,
                                           output_size=args.output_size, dark_outside=args.dark_outside)
    _check_request_prompt(request)
    job = GenerateJob(seams, request, _iterations(args, scene), capture=capture, device=args.device)
    out = job.run_to_completion(on_progress=headless.print_progress)
    summary = out["summary"]
    figures = dict(summary["metrics"])
    if args.refine:  # closed loop on the rig, before the render: the render then captures the refined image(s)
        from ..services.refine.refine_job import RefineResultJob

        figures["refine"] = RefineResultJob(seams, args.refine).run_to_completion(
            on_progress=headless.print_progress)["refine"]
        figures.update(read_summary_of(out["folder"])["metrics"])
    if args.render:
        figures.update(RenderResultJob(seams).run_to_completion()["metrics"])
    _save_if_asked(args)
    print_notes(result_notes(summary))
    if not args.save:
        print_notes([f"this result is not saved into the .blend (no --save): export it with "
                     f"'export --result {out['folder']}'"])
    print(f"Look at {os.path.join(out['folder'], 'comparison.png')}")
    lgst = summary["lgst"]
    images = {"style_images": [(i["path"], i["weight"]) for i in lgst.get("style_images", [])]}
    images = images if images["style_images"] else {}
    several = {key: summary[key] for key in ("projectors", "multi") if key in summary}  # a result of several
    print_json({"result": out["folder"], "styles": lgst.get("styles"), "understood": lgst.get("understood"),
                "models": (summary.get("models") or {}).get("line"), "device": summary.get("device"),
                **images, **several, **figures})
    return 0


def _check_request_prompt(request) -> None:
    """A prompt the default backend reads (no mix, no style image) is refused before any model loads when nothing
    of it is understood (one line: 'no look matched ...')."""
    from ...lapig_core.lgst import DEFAULT_BACKEND
    from ...lapig_core.lgst.not_understood import check_prompt

    if request.lgst_backend() == DEFAULT_BACKEND and not request.mix.strip() and request.prompt.strip():
        check_prompt(request.prompt)


def read_summary_of(folder) -> dict:
    from ...lapig_core.export.result_files import read_summary

    return read_summary(folder)


def cmd_export(args) -> int:
    from ..services.export import export_result

    if args.crossfade and not os.path.isdir(os.path.dirname(os.path.abspath(args.crossfade))):
        raise ValueError(f"--crossfade: the folder above {args.crossfade} does not exist")  # before any file
    scene = _open_scene(args)
    store = BlenderSceneStore(scene)
    result = os.path.abspath(args.result) if args.result else _scene_result_if_latest(scene)
    settings = scene_state.export_settings(scene, path=os.path.abspath(args.out), bit_depth=args.bit_depth,
                                           crossfade_frames=args.frames)
    written = export_result.export_current(store, settings, result,
                                           mpcdi=os.path.abspath(args.mpcdi) if args.mpcdi else None,
                                           profile=getattr(args, "profile", "2d") or "2d",
                                           mpcdi_version=getattr(args, "mpcdi_version", "2.0") or "2.0")
    summary = {"result": result or scene_state.read(scene).result_dir,
               **{k: str(v) if isinstance(v, os.PathLike) else v for k, v in written.items()}}
    if args.crossfade:  # several projectors: a folder per projector, <crossfade>/projector_<k>/
        frames = export_result.export_crossfade(store, os.path.abspath(args.crossfade), settings, result,
                                                on_progress=headless.print_progress)
        summary["crossfade_frames"] = len(frames)
    print_json(summary)
    return 0


def _scene_result_if_latest(scene) -> str:
    """The scene's result, unless a later stylize (one without --save) made a newer one: a pipeline that
    stylizes and then exports means that one, so say how to choose instead of exporting the old look."""
    from ..services.export import export_result

    recorded = scene_state.read(scene).result_dir
    newest = export_result.newest_result(os.path.join(storage.data_root()[0], "results"))
    if newest and os.path.normpath(newest) != os.path.normpath(recorded or ""):
        held = f"the .blend holds {recorded}" if recorded else "the .blend holds no result"
        raise ValueError(f"{held}, but stylize made {newest} after it without --save: pass --result {newest} "
                         f"to export that one" + (f", or --result {recorded} for the .blend's" if recorded else ""))
    return recorded


def _chosen_capture(args, store) -> str | None:
    """--capture (absolute), else None for the .blend's own capture, unless a later capture (one without
    --save) made a newer one: a pipeline that captures and then trains means that one, so say how to choose
    instead of training on the old capture."""
    if args.capture:
        return os.path.abspath(args.capture)
    from ..services.capture.captures import newest_capture

    state = store.read()
    recorded = state.capture_dir
    newest = newest_capture(store.data_root(), state.rig.fingerprint)
    if newest and os.path.normpath(newest) != os.path.normpath(recorded or ""):
        if recorded:  # two paths, in full, so a pipeline can copy either (one_line keeps 500 characters)
            raise ValueError(f"capture made a newer capture than the .blend's without --save: pass --capture {newest} "
                             f"to use it, or --capture {recorded} for the .blend's")
        raise ValueError(f"the .blend holds no capture, but capture made one without --save: pass --capture {newest}")
    return None


def _iterations(args, scene) -> int | None:
    """Fine-tuning iterations per network: --iterations, else the scene's setting."""
    return args.iterations if args.iterations is not None else scene_state.finetune_iterations(scene)


def cmd_show_export(args) -> int:
    """The scene's show, per projector, as a video or a PNG sequence with its sidecar (show-export)."""
    from ..blender import show_timeline

    scene = _open_scene(args)
    job = show_timeline.export_job(scene, os.path.abspath(args.out), args.codec, args.bit_depth)
    out = job.run_to_completion(on_progress=headless.print_progress)
    print_notes(out.get("notes", []))
    print_json(out)
    return 0


def _play_timeline(scene, display: str, displays=None) -> int:
    """show --timeline: the scene's show on the projector window at its frame rate; the late frames printed. A rig
    of several (``displays``: one display per projector): every projector's window, each its own frames of the
    show, presented together (the figures add max_skew_frames)."""
    from ..blender import show_timeline
    from ..rigs import live_output

    problem = show_timeline.blocker(scene)
    if problem:  # before the window opens
        raise ValueError(problem)
    if displays:
        windows = live_output.open_windows(displays, names=[f"projector {k + 1}" for k in range(len(displays))])
        sink = live_output.make_live(live_output.LockedWindowsSink(windows, fps=scene_state.scene_fps(scene) or 60.0))
        where = {"displays": [w.describe().get("display") for w in windows.windows]}
    else:
        sink = live_output.open_live(display)
        where = {"display": sink.window.describe()["display"]}
    try:
        played = show_timeline.play_job(scene, sink).run_to_completion(on_progress=headless.print_progress)
        print_json({**where, "show": played})
    finally:
        live_output.close_live()
    return 0


def _several_displays(args, store, count: int, whose: str = "the rig") -> list:
    """The displays of a rig of several (--display 1,2,.. or the scene's real rig's), one per projector of
    `whose` (the rig, or the result played)."""
    from ..services.panel.panel_state import projectors_blocker

    rig = store.read().rig
    displays = [d.strip() for d in args.display.split(",")] if args.display else list(rig.displays)
    if len(displays) != count or not all(displays):
        raise ValueError(f"{whose} has {count} projectors: give --display one display each, e.g. "
                         f"--display {','.join(str(k + 1) for k in range(count))}")
    if not args.display:
        refuse(projectors_blocker(rig))
    return displays


def cmd_show(args) -> int:
    """The scene's look on the projector window, live, until Esc in the window (or --seconds); --timeline: its
    show."""
    from ...lapig_core.multi.result_files import is_multi_result
    from ..rigs import live_output
    from ..services.export import crossfade, export_result

    scene = _open_scene(args)
    store = BlenderSceneStore(scene)
    count = store.read().rig.projector_count
    several = count > 1
    if args.timeline and several:
        return _play_timeline(scene, "", _several_displays(args, store, count))
    display = args.display or getattr(scene_state.real_rig_spec(scene), "display", "").strip()
    if not display:
        raise ValueError("show needs --display (or a scene with a real rig: capture --rig real --save)")
    if args.timeline:
        return _play_timeline(scene, display)
    folder = os.path.abspath(args.result) if args.result else _scene_result_if_latest(scene)
    if not folder:
        raise ValueError("the scene has no result yet: run stylize first, or pass --result")
    if is_multi_result(folder) or several:
        return _show_several(args, scene, store, folder)
    settings = scene_state.export_settings(scene, crossfade_frames=args.frames)
    frame = export_result.result_frame(store, folder, settings.bit_depth)
    sink = live_output.open_live(display)
    try:
        summary = {"display": sink.window.describe()["display"], "result": folder}
        if args.crossfade:
            sets = crossfade.frame_sets(store, folder, settings.bit_depth, settings.crossfade_frames)
            frames = (frame for [frame] in sets)  # one projector's
            summary["crossfade"] = live_output.play(sink.window, frames, fps=args.fps)
        t = time.perf_counter()
        sink.show(frame)
        refuse(sink.problem)
        summary["show_s"] = round(sink.shown_at - t, 4)
        print(f"showing {folder} on display {summary['display'].get('name')}: Esc in the window stops"
              if args.seconds is None else f"showing {folder} for {args.seconds:g} s")
        print_json(summary)
        _until_closed(sink.window, args.seconds)
    finally:
        live_output.close_live()
    return 0


def _until_closed(window, seconds) -> None:
    """Wait while the window (or windows) stays open: until Esc in it, or `seconds` (None: no end)."""
    deadline = None if seconds is None else time.perf_counter() + seconds
    while window.is_open and (deadline is None or time.perf_counter() < deadline):
        time.sleep(0.05)


def _show_several(args, scene, store, folder: str) -> int:
    """show for a rig of several projectors: every projector's window at once, each on its display (--display
    1,2,.. or the scene's real rig's), its own image of the result; the windows present together, and the lock
    is measured over --lock-frames presentations at --fps (max_skew_frames: the spread between the windows)."""
    from ...lapig_core.multi.result_files import is_multi_result
    from ...lapig_core.rig.frame_lock import play_locked
    from ..rigs import live_output

    if not is_multi_result(folder):
        raise ValueError("the rig has several projectors but the result is of one: stylize again first")
    frames = live_output.result_frames(folder, scene_state.export_settings(scene).bit_depth)
    displays = _several_displays(args, store, len(frames), "the result")
    windows = live_output.open_windows(displays, names=[f"projector {k + 1}" for k in range(len(frames))])
    sink = live_output.make_live(live_output.LockedWindowsSink(windows, fps=args.fps))
    try:
        crossfade = None
        if args.crossfade:  # each projector's crossfade on its window, presented together
            settings = scene_state.export_settings(scene, crossfade_frames=args.frames)
            crossfade = live_output.CrossfadeJob(sink, store, folder, settings.crossfade_frames, args.fps,
                                                 settings.bit_depth).run_to_completion()
        t = time.perf_counter()
        sink.show_all(frames)
        refuse(sink.problem)
        summary = {"displays": [w.describe().get("display") for w in windows.windows], "result": folder,
                   "show_s": round(time.perf_counter() - t, 4), **({"crossfade": crossfade} if crossfade else {})}
        if args.lock_frames:
            summary["lock"] = play_locked(windows, (sink.frames for _ in range(args.lock_frames)), fps=args.fps)
        print(f"showing {folder} on {len(frames)} projectors: Esc in a window stops"
              if args.seconds is None else f"showing {folder} on {len(frames)} projectors for {args.seconds:g} s")
        print_json(summary)
        _until_closed(windows, args.seconds)
    finally:
        live_output.close_live()
    return 0


def cmd_devices(args) -> int:
    """The displays and the cameras a real rig can use, for --display and --camera."""
    from ...lapig_core.rig import RigError
    from ...lapig_core.rig.cameras import list_cameras
    from ...lapig_core.rig.projector_window import list_displays

    try:
        displays = list_displays()
    except RigError as exc:
        displays = {"error": str(exc)}
    print_json({"displays": displays, "cameras": list_cameras()})
    return 0
