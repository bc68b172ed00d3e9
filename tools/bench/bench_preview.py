"""`python -m lapig_addon bench preview --json`: from Generate to the adapted look in the preview.

The artist's path on the demo scene (800x600 projector): capture and Train once, then Generate twice
through the same job the panel runs (GenerateJob: PSA at the working frame, the look and its compensation
at native resolution, the result folder), each followed by the preview of the look on the object
(result_preview.apply_mode TARGET, as the panel's Preview button). The second Generate is the warm one
of the issue: the models are fine-tuned and the text model is loaded. Figures: prompt_to_preview_seconds
(warm) and _cold (the first, which loads the text and style models), with the job's own split.

The session's warm-up (services/warmup) starts with the capture, as it does in Blender when Capture is pressed
(--no-warmup: the session as it was before it).

Before Train, the first look (issue 28): right after Capture, which ends by fitting the classical model, two
Generates with no Train (the classical model compensates and is PSA's simulator), each to the preview, then the
rig renders the first one's projector images: capture_to_first_look_seconds_cold (the first job of the session,
which loads the text and style models) and capture_to_first_look_seconds (warm), each the first look's fit plus
Generate plus the preview, and rendered_psnr_first_look beside rendered_psnr_trained (the same prompt after Train).
The Generates after Train are then no longer the session's first: prompt_to_preview_seconds_cold becomes
prompt_to_preview_seconds_after_first_look (the models loaded already).

The stop rule ends most prompts' PSA early, so the warm prompts alone may never show a PSA that runs to
its cap. The last run is that worst case on purpose: the first prompt again, warm, with the stop rule
off (PSA runs the warm start and every joint step), reported as prompt_to_preview_seconds_capped.
"""
from __future__ import annotations

import os
import platform
import time

import bpy

from ...lapig_core.psa import adaptation
from ...lapig_addon.blender import result_preview, scene_state
from ...lapig_addon.blender.scene_store import scene_seams
from ...lapig_addon.cli import headless
from ...lapig_addon.services import warmup
from ...lapig_addon.services.generate.generate_job import GenerateJob
from ...lapig_addon.services.train.train_job import TrainModelsJob
from ...lapig_addon.services.render.render_job import RenderResultJob
from .io_count import counted_io

# the first Generate is the cold one; the rest are warm, on prompts whose PSA runs to different lengths
PROMPTS = ("Render it in the style of a Van Gogh oil painting", "Make it a stained glass artwork",
           "Make it a charcoal sketch", "Make it a woodcut print")


def _generate_to_preview(scene, prompt, iterations, capped=False) -> dict:
    request = scene_state.generate_request(scene, prompt=prompt)
    stop_ratio_for = adaptation.stop_ratio_for
    if capped:  # the stop rule never met: every joint step runs (PSASettings reads the rule at creation)
        adaptation.stop_ratio_for = lambda _a: 0.0
    try:
        t = time.perf_counter()
        with counted_io() as io:  # what Generate reads and writes, to the preview
            generated = GenerateJob(scene_seams(scene), request, iterations).run_to_completion()
        generated_s = time.perf_counter() - t
    finally:
        adaptation.stop_ratio_for = stop_ratio_for
    shown = result_preview.apply_mode(scene, "TARGET")
    total = time.perf_counter() - t
    summary = generated["summary"]
    return {"prompt": prompt, "seconds": round(total, 2), "generate_seconds": round(generated_s, 2),
            "preview_seconds": round(total - generated_s, 2), "previewed": bool(shown),
            "psa_seconds": summary["metrics"].get("psa_seconds"),
            "psa_iterations": summary["metrics"].get("psa_iterations"), "capped": capped,
            "native_output": summary.get("native_output"), "io": io,
            "first_look": bool((summary.get("models") or {}).get("first_look"))}


def _rendered(scene) -> dict:
    """The scene's result projected and captured by the rig (Render Real Capture): its rendered PSNRs."""
    m = RenderResultJob(scene_seams(scene)).run_to_completion()["metrics"]
    return {k: round(m[k], 3) for k in ("rendered_psnr", "rendered_psnr_nopsa", "rendered_psnr_native") if k in m}


def _first_look(scene, captured, iterations) -> dict:
    """Two Generates right after Capture, no Train: the first look (cold, then warm), and the first one rendered."""
    fit_s = captured.get("first_look_seconds")
    if fit_s is None:
        raise RuntimeError(f"the capture fitted no first look: {captured.get('first_look_error', 'no reason given')}")
    cold = _generate_to_preview(scene, PROMPTS[0], iterations)
    rendered = _rendered(scene)
    warm = _generate_to_preview(scene, PROMPTS[1], iterations)
    for r in (cold, warm):
        if not r["first_look"]:
            raise RuntimeError("Generate after Capture did not use the first look")
    return {"capture_to_first_look_seconds": round(fit_s + warm["seconds"], 2),
            "capture_to_first_look_seconds_cold": round(fit_s + cold["seconds"], 2),
            "first_look_fit_seconds": fit_s, "first_look_runs": [cold, warm], "rendered_first_look": rendered}


def run(args) -> dict:
    out = os.path.abspath(args.out or os.path.join("out", "bench_preview"))
    os.makedirs(out, exist_ok=True)
    scene, *_ = headless.build_demo_setup("panel", "sakura", folder=out, seed=args.seed)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(out, "preview.blend"))
    scene = bpy.context.scene
    settings = scene_state.capture_settings(scene, train_count=args.train, test_count=0, seed=args.seed)
    if args.warmup:  # as in Blender, where pressing Capture (the add-on's first use) starts it
        warmup.start_warmup()
    t = time.perf_counter()
    captured = headless.run_capture(scene, settings)  # recorded in the scene; ends with the first look's fit
    capture_s = time.perf_counter() - t
    first_look = _first_look(scene, captured, args.iterations)
    t = time.perf_counter()
    TrainModelsJob(scene_seams(scene), args.iterations).run_to_completion()
    train_s = time.perf_counter() - t
    runs = [_generate_to_preview(scene, PROMPTS[0], args.iterations)]
    trained = _rendered(scene)  # the same prompt as the first look's cold Generate, with Train's models
    runs += [_generate_to_preview(scene, prompt, args.iterations) for prompt in PROMPTS[1:]]
    capped = _generate_to_preview(scene, PROMPTS[0], args.iterations, capped=True)
    if not args.json:
        for r in runs:
            print(f"{r['prompt']}: {r['seconds']} s (Generate {r['generate_seconds']} s, PSA {r['psa_seconds']} s, "
                  f"preview {r['preview_seconds']} s)", flush=True)
    warm = [r["seconds"] for r in runs[1:]]
    look = {k: v for k, v in first_look.items() if k != "rendered_first_look"}
    return {"benchmark": "preview", **look, "first_look_goal_seconds": 10.0, "first_look_goal_seconds_cold": 20.0,
            "rendered_psnr_first_look": first_look["rendered_first_look"], "rendered_psnr_trained": trained,
            "rendered_prompt": PROMPTS[0], "loadavg_1m": round(os.getloadavg()[0], 2),
            "prompt_to_preview_seconds": runs[1]["seconds"],
            "prompt_to_preview_seconds_warm_mean": round(sum(warm) / len(warm), 2),
            "prompt_to_preview_seconds_warm_max": max(warm),
            "prompt_to_preview_seconds_after_first_look": runs[0]["seconds"], "goal_seconds": 10.0,
            "prompt_to_preview_seconds_capped": capped["seconds"], "capped_psa_iterations": capped["psa_iterations"],
            "generate_io_warm": runs[1]["io"],
            "runs": runs + [capped],
            "capture_seconds": round(capture_s, 1), "train_seconds": round(train_s, 1),
            "projector": [scene.lapig.projector.lapig_projector.resolution_x,
                          scene.lapig.projector.lapig_projector.resolution_y],
            "working_size": scene.lapig.working_size, "train_pairs": args.train,
            "warmup": {"started_with_capture": args.warmup, **warmup.warmup_state()},
            "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores"}
