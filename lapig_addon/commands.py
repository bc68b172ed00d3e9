"""Implementations of the CLI commands (bpy work happens here, on the main thread)."""
from __future__ import annotations

import os
import time

import bpy
import numpy as np

from ..lapig_core import dataset as ds
from ..lapig_core.imageio import read_image, write_png
from ..lapig_core.sheets import labelled_grid
from . import addon, headless, storage
from .capture_job import CaptureSettings
from .cli import print_json


def _ensure_registered():
    if not addon.is_registered():
        addon.register()


def cmd_demo(args) -> int:
    _ensure_registered()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    scene, projector, camera, target = headless.build_demo_setup(args.shape, args.surface, folder=out,
                                                                 seed=args.seed)
    settings = CaptureSettings(out_dir=os.path.join(out, "dataset"), setup_name=f"{args.shape}_{args.surface}",
                               train_count=args.train, test_count=args.test, seed=args.seed)
    result = headless.run_capture(scene, settings, progress=headless.print_progress)
    sheet_path = os.path.join(out, "contact_sheet.png")
    write_png(sheet_path, contact_sheet(result["setup_dir"]))
    scene.lapig.last_capture_dir = str(result["setup_dir"])
    scene.lapig.last_capture_fingerprint = result["meta"]["fingerprint"]
    blend_path = os.path.join(out, "demo.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend_path)
    meta = result["meta"]
    summary = {"contact_sheet": sheet_path, "blend": blend_path, "setup_dir": str(result["setup_dir"]),
               "valid_fraction": meta["valid_fraction"], **meta["registration"],
               "total_s": round(time.perf_counter() - t0, 2)}
    print(f"Look at {sheet_path}")
    print_json(summary)
    return 0


def contact_sheet(setup_dir) -> np.ndarray:
    """Raw and registered references, a few Gray-code captures, and training pairs."""
    layout = ds.DatasetLayout(os.path.dirname(os.path.dirname(setup_dir)), os.path.basename(setup_dir))
    images, labels = [], []
    for i, name in enumerate(["I- (black)", "I+ (white)", "s (gray)"], start=1):
        images.append(read_image(layout.image_path(layout.cam_raw_dir("ref"), i)))
        labels.append(f"raw {name}")
    for i, name in enumerate(["I- (black)", "I+ (white)", "s (gray)"], start=1):
        images.append(read_image(layout.image_path(layout.cam_warp_dir("ref"), i)))
        labels.append(f"registered {name}")
    for i in (1, 7, 15):
        images.append(read_image(layout.image_path(layout.cam_raw_dir("sl"), i)))
        labels.append(f"Gray code {i}")
    for i in (1, 2, 3):
        images.append(read_image(layout.image_path(layout.prj_dir("train"), i)))
        labels.append(f"projected train {i}")
        images.append(read_image(layout.image_path(layout.cam_raw_dir("train"), i)))
        labels.append(f"raw capture {i}")
        images.append(read_image(layout.image_path(layout.cam_warp_dir("train"), i)))
        labels.append(f"registered capture {i}")
    return labelled_grid(images, labels, columns=6, cell=220, title=f"LAPIG capture set: {layout.setup}")


def cmd_capture(args) -> int:
    _ensure_registered()
    if args.blend:
        if not os.path.isfile(args.blend):
            raise ValueError(f"no such .blend file: {args.blend}")
        bpy.ops.wm.open_mainfile(filepath=args.blend)
    scene = bpy.context.scene
    s = scene.lapig
    if s.target is None:
        raise ValueError("the scene has no LAPIG rig: add the projector and camera first (or run 'demo')")
    settings = CaptureSettings(out_dir=os.path.abspath(args.out),
                               setup_name=args.setup or storage.setup_name_for(s.target),
                               train_count=args.train, test_count=args.test, working_size=args.size,
                               samples=args.samples, pattern_folder=args.patterns, seed=args.seed)
    result = headless.run_capture(scene, settings, progress=headless.print_progress)
    print_json({"setup_dir": str(result["setup_dir"]), **result["meta"]["registration"],
                "valid_fraction": result["meta"]["valid_fraction"]})
    return 0


def cmd_bench(args) -> int:
    _ensure_registered()
    from . import bench_capture, bench_models

    args.out = args.out or f"out/bench_{args.what}"
    summary = {"capture": bench_capture, "models": bench_models}[args.what].run(args)
    if not args.json:
        for key, value in sorted(summary.items()):
            print(f"{key:36s} {value}")
    print_json(summary)
    return 0


def cmd_dataset(args) -> int:
    _ensure_registered()
    from . import synthetic_setups as syn

    if args.setups == "pretrain":
        specs = syn.PRETRAIN_SETUPS
    elif args.setups == "bench":
        specs = syn.BENCH_SETUPS
    else:
        specs = [syn.get_spec(name.strip()) for name in args.setups.split(",") if name.strip()]
    summary = headless.render_synthetic_setups(specs, args.out, args.train, args.test, args.seed,
                                               skip_existing=args.skip_existing, sheet=contact_sheet)
    print_json(summary)
    return 0


def cmd_pretrain(args) -> int:
    from ..lapig_core import pretrain

    names = {"compennest": ("CompenNeSt", "compensation"), "pcnet": ("PCNet", "simulation"),
             "reversed": ("CompenNeSt", "simulation")}
    jobs = [names[n] for n in args.only] if args.only else list(pretrain.JOBS)
    sets = pretrain.load_setups(args.data)
    print(f"pretraining on {len(sets)} setups: {', '.join(cs.setup for cs in sets)}", flush=True)
    summary = {}
    for arch, role in jobs:
        key = f"{arch}_{role}"
        summary[key] = pretrain.pretrain_one(sets, arch, role, args.iterations, args.out, crop=args.crop,
                                             seed=args.seed,
                                             on_progress=lambda p, m, k=key: print(f"{k}: {m}", flush=True))
        print(f"{key}: {summary[key]}", flush=True)
    print_json(summary)
    return 0


def cmd_eval(args) -> int:
    _ensure_registered()
    from . import evaluate

    summary = evaluate.run(args)
    print(f"Look at {summary['sheet']}")
    print_json({k: summary[k] for k in ("with_psa", "without_psa", "style_retention", "timings", "sheet")})
    return 0


def cmd_build(args) -> int:
    from .packaging import build_extension

    path = build_extension(os.path.abspath(args.out))
    print(f"built and validated {path}")
    return 0
