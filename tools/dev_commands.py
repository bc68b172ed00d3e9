"""Developer commands of `python -m lapig_addon`: benchmarks, data sets, pretraining, evaluation, build.

They live outside the shipped extension (tools/ is excluded from the zip); the CLI adds them when
this package is importable, i.e. in a source checkout.
"""
from __future__ import annotations

import argparse
import os

from ..lapig_addon.blender import addon
from ..lapig_addon.cli.commands import contact_sheet
from ..lapig_addon.cli.options import ranged_option
from ..lapig_addon.cli.output import print_json

# `bench NAME` runs tools/bench/bench_<module>.py's run(args), which returns the JSON summary
BENCHMARKS = {"capture": "capture", "models": "models", "psa": "psa", "ui": "ui", "frame": "frame",
              "preview": "preview", "prompts": "prompts", "style-images": "style_images",
              "transport": "transport", "learned-variants": "learned_variants",
              "pcnet-through": "pcnet_through", "hardware": "hardware", "refine": "refine",
              "train-step": "train_step", "light": "light", "finetune-length": "finetune_length",
              "classical-fit": "classical_fit", "rig-faults": "rig_faults", "device": "device",
              "show": "show", "show-live": "show_live", "video": "video", "multi": "multi",
              "multi-live": "multi_live", "show-multi": "show_multi",
              "denormals": "denormals", "layout": "layout", "threads": "threads", "looks": "looks",
              "machine": "machine", "diffusion": "diffusion", "structure": "structure"}


def _ensure_registered():
    if not addon.is_registered():
        addon.register()


def pair_of(kind, example: str):
    """An argparse type for 'AxB' (e.g. 1920x1080 pixels, 3.6x2 metres)."""
    def parse(text: str):
        try:
            a, b = (kind(v) for v in text.lower().split("x"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"must look like {example}, got '{text}'") from None
        if a <= 0 or b <= 0:
            raise argparse.ArgumentTypeError(f"both sides must be positive, got '{text}'")
        return a, b
    return parse


pixels = pair_of(int, "1920x1080")


def add_parsers(sub):
    data = sub.add_parser("dataset", help="render the synthetic setups used for pretraining and benchmarks")
    data.add_argument("--setups", default="pretrain",
                      help="'pretrain', 'bench', or comma-separated setup names (default: pretrain)")
    data.add_argument("--out", default="out/pretrain_data", help="data set root folder")
    ranged_option(data, "--train", "train_count", "training captures per setup (default 125)", default=125)
    ranged_option(data, "--test", "test_count", "test captures per setup (default 20)", default=20)
    ranged_option(data, "--seed", "seed", "pattern seed", default=0)
    data.add_argument("--skip-existing", action="store_true", help="keep setups that are already complete")

    pre = sub.add_parser("pretrain", help="pretrain CompenNeSt, PCNet and CompenNeSt reversed on rendered setups")
    pre.add_argument("--data", default="out/pretrain_data", help="data set root from 'dataset'")
    pre.add_argument("--out", default="lapig_core/photometric/weights", help="folder for the weights")
    ranged_option(pre, "--iterations", "pretrain_iterations", "iterations per network (default 2000)", default=2000)
    ranged_option(pre, "--crop", "crop", "random crop size (default 96)", default=96)
    pre.add_argument("--only", choices=["compennest", "pcnet", "reversed"], action="append",
                     help="train only these networks (repeatable)")
    ranged_option(pre, "--seed", "seed", "initialisation and crop seed", default=0)

    ev = sub.add_parser("eval", help="one surface image and prompt: stylize with and without PSA, capture both")
    ev.add_argument("--surface", required=True, help="surface texture image (PNG/JPG)")
    ev.add_argument("--prompt", required=True, help='e.g. "Make it a stained glass artwork"')
    ev.add_argument("--out", required=True, help="output folder (sheet.png, metrics.json)")
    ev.add_argument("--backend", default="styletransfer", help="LGST backend (default: styletransfer)")
    ranged_option(ev, "--seed", "seed", "pattern and style seed", default=0)
    ranged_option(ev, "--train", "train_count", "captured training pairs (default 125)", default=125)
    ranged_option(ev, "--psa-iterations", "psa_iterations", "PSA iteration cap (default 30)", default=30)
    ranged_option(ev, "--iterations", "finetune_iterations",
                  "fine-tuning iterations per network (default: the CPU recipe's); fewer: rough but quick")
    ev.add_argument("--verbose", action="store_true", help="print training progress")
    ranged_option(ev, "--refine", "refine_iterations", "also refine the PSA look's projector image on the rig, at "
                  "most N steps, and write with_refine beside with_psa in metrics.json (default 0: no)", default=0)
    ranged_option(ev, "--adaptation", "psa_adaptation", "PSA adaptation, 0 keep my look .. 1 whatever the surface "
                  "can show (default 0.5)", default=0.5, type=float)
    ev.add_argument("--projector", type=pixels, default=(800, 600), help="projector resolution (default 800x600)")
    ev.add_argument("--throw-ratio", type=float, default=1.5, help="projector throw ratio (default 1.5)")
    ev.add_argument("--wall", type=pair_of(float, "3.6x2"), default=None,
                    help="the wall panel's width x height in metres (default 2x2), e.g. 3.6x2 for a wide facade")
    ev.add_argument("--camera", type=pixels, default=(480, 360), help="camera resolution (default 480x360)")
    ev.add_argument("--working-size", type=int, default=256, help="long side of the working frame (default 256)")
    ev.add_argument("--output-size", type=int, default=0,
                    help="long side of the final projector image (default 0: the projector's native frame)")

    build = sub.add_parser("build", help="build and validate the extension zip with Blender's extension CLI")
    build.add_argument("--out", default="dist", help="output folder (default: dist)")
    build.add_argument("--platform", action="append", default=None,
                       help="also build the zip that carries its Python wheels for this platform: linux-x64, "
                            "windows-x64, macos-arm64 or all (repeatable); without it, the zip without wheels")
    build.add_argument("--python", choices=["py311", "py313", "all"], default="all",
                       help="with --platform: the zip for Blender's Python: py311 (official Blender 4.2 to 5.0), "
                            "py313 (official 5.1 and later, and distributions' builds on Python 3.13) or all "
                            "(default)")
    build.add_argument("--lock", action="store_true",
                       help="rewrite requirements-bundle.txt from this environment first")

    bench = sub.add_parser("bench", help="benchmarks that print one JSON object as their last line")
    bench.add_argument("what", choices=sorted(BENCHMARKS), help="which benchmark")
    bench.add_argument("--json", action="store_true", help="print only the JSON summary at the end")
    bench.add_argument("--out", default=None, help="output folder (default: out/bench_WHAT)")
    bench.add_argument("--patterns", type=int, default=40, help="train+test captures to time (default 40)")
    bench.add_argument("--camera", default="480x360", help="capture resolution WxH (default 480x360)")
    bench.add_argument("--shape", default="panel", choices=["panel", "box", "statue"],
                       help="capture: demo object (default: panel, the demo scene)")
    bench.add_argument("--data", default="out/bench_data",
                       help="models: data set root of the benchmark setups (rendered when missing)")
    bench.add_argument("--setups", type=int, default=3, help="models: how many benchmark setups (default 3)")
    ranged_option(bench, "--iterations", "finetune_iterations",
                  "models, psa: fine-tuning iterations per model (default: the CPU recipe's)")
    bench.add_argument("--compensate", type=int, default=8, help="models: compensated test images per setup")
    bench.add_argument("--no-timing", dest="timing", action="store_false",
                       help="models: skip the fine-tuning time measurement")
    bench.add_argument("--compensation-pairs", type=int, default=8,
                       help="models: pairs CompenNeSt is fine-tuned on (default 8, as the paper)")
    bench.add_argument("--compensation-only", action="store_true",
                       help="models: only the rendered compensation (skips the PCNet table)")
    bench.add_argument("--timing-only", action="store_true",
                       help="models: only the fine-tuning time measurement (on the first setup)")
    bench.add_argument("--surfaces", type=int, default=5, help="psa: how many surfaces (default 5)")
    bench.add_argument("--prompts", type=int, default=10, help="psa: how many prompts (default 10)")
    bench.add_argument("--ablation-prompts", type=int, default=3,
                       help="psa: prompts per surface that also run the loss ablation (default 3)")
    bench.add_argument("--sheet-prompts", type=int, default=5, help="psa: prompts per surface on the sheets")
    bench.add_argument("--table", choices=["paper", "hard", "both", "realistic"], default="both",
                       help="psa: the paper's Table 1/2 surfaces, the hard surfaces of issue 13, both, or Table 1 "
                            "on the realistic-transport corner and bust (issue 16)")
    bench.add_argument("--no-resample", dest="resample", action="store_false",
                       help="psa: leave out the resample baseline (the public code's PSA)")
    ranged_option(bench, "--adaptation", "psa_adaptation", "psa: PSA adaptation (default 0.5)", default=0.5,
                  type=float)
    bench.add_argument("--backend", default="styletransfer", help="psa/ui: LGST backend")
    bench.add_argument("--psa-surfaces", type=int, default=0,
                       help="prompts, style-images: also run PSA (Table 1, Cycles) on this many captured "
                            "surfaces (default 0: prompts: adherence and sheets; style-images: parity, timing, sheet)")
    bench.add_argument("--psa-named", action="store_true",
                       help="prompts: the PSA check on named prompts of the art lexicon (Klimt, Mondrian, ...)")
    ranged_option(bench, "--train", "train_count", "psa: captured training pairs per surface", default=125)
    ranged_option(bench, "--psa-iterations", "psa_iterations", "psa: PSA iteration cap (default 20)")
    ranged_option(bench, "--seed", "seed", "pattern and style seed", default=0)
    bench.add_argument("--threads", type=int, default=2, help="style-images: torch threads (default 2)")
    bench.add_argument("--show-rendered", action="store_true",
                       help="show: also render the frames with Cycles on a demo panel (minutes)")
    ranged_option(bench, "--working-size", "working_size", "style-images: working size of the PSA captures")
    bench.add_argument("--no-warmup", dest="warmup", action="store_false",
                       help="ui, preview: no warm-up before the first job (the session as it was before issue 28)")
    bench.add_argument("--lengths", default=None,
                       help="finetune-length: CompenNeSt fine-tune lengths in iterations (default 1000,500)")
    bench.add_argument("--variants", default=None,
                       help="finetune-length: also the recipes a GPU makes affordable, comma-separated: paper_whole "
                            "(the paper's recipe, whole images, 8 pairs), app_whole (the app's, whole images)")
    bench.add_argument("--repeats", type=int, default=3, help="classical-fit: fits per path (default 3)")
    bench.add_argument("--capture", default=None,
                       help="train-step, classical-fit, layout, threads: the captured setup whose pairs Train fine-tunes on "
                            "(e.g. the demo's; layout, threads: default the device check's fixture)")
    bench.add_argument("--weights", default=None,
                       help="models, transport: folder of the pretrained weights the fine-tunes start from "
                            "(default: the shipped lapig_core/photometric/weights)")
    bench.add_argument("--parts", default="",
                       help="transport: comma-separated parts (look, defocus, interreflection, noise, speed, compensation, "
                            "pcnet, headroom; default: all but pcnet and headroom); ui: psa, window, panel, install "
                            "(default: all four)")
    bench.add_argument("--transport-data", default="out/transport_data",
                       help="transport: data set root of the realistic setups (rendered when missing)")
    bench.add_argument("--realistic-setups", type=lambda t: [n.strip() for n in t.split(",") if n.strip()],
                       default=[], help="transport: comma-separated realistic setup names (default: all)")
    bench.add_argument("--train-pairs", type=int, default=125, help="transport: training pairs captured per setup")
    bench.add_argument("--test-pairs", type=int, default=16,
                       help="transport: test pairs per setup (the first --compensate are compensated, the rest "
                            "validate the choice)")
    bench.add_argument("--pair-counts", type=lambda t: [int(n) for n in t.split(",")], default=[125, 8],
                       help="transport: CompenNeSt fine-tuning pair counts (default 125,8: the first is the app's, "
                            "all the captured pairs; 8 is the paper's)")
    bench.add_argument("--refine-data", default="out/refine_data",
                       help="refine: data set root of the refinement's setups (rendered when missing)")
    bench.add_argument("--refine-iterations", type=int, default=6,
                       help="refine: the cap on refinement steps (default 6)")
    bench.add_argument("--refine-damping", type=float, default=0.8,
                       help="refine: the step's damping at first (default 0.8, the app's)")
    bench.add_argument("--machine-speed", action="store_true",
                       help="refine: run ../shared/machine_speed.py after the figures and put its torch_step_s in the JSON")
    bench.add_argument("--lens-radius-mm", type=float, default=60.0,
                       help="transport: the projector's lens radius for the defocus figure (default 60)")
    bench.add_argument("--min-blur-px", type=float, default=1.0,
                       help="transport: smallest predicted blur radius counted in the defocus error (default 1)")
    bench.add_argument("--interreflection-camera", type=lambda t: tuple(int(v) for v in t.lower().split("x")),
                       default=(480, 360), help="transport: camera size of the inter-reflection figure (default "
                                                "480x360, the captures'; its reference takes minutes)")
    bench.add_argument("--reference-samples", type=int, default=1024,
                       help="transport: samples of the converged inter-reflection reference (default 1024)")
    bench.add_argument("--unseen", action="store_true",
                       help="looks: add the suite's held-back prompts (tools/bench/looks_suite.toml)")
    bench.add_argument("--prompts-like", default=None, help="looks: only the suite's prompts containing this text")
    bench.add_argument("--psa", action="store_true", help="looks: also PSA's gain per family (the device check capture)")
    bench.add_argument("--models", default="",
                       help="diffusion: a models folder whose real models' state is reported (default: $LAPIG_MODELS_DIR)")
    from .bench.bench_device import add_arguments as device_arguments

    device_arguments(bench)  # device: --device, --paper-iterations, --frames, --write-cpu-figures, ...
    for name, func in (("dataset", cmd_dataset), ("pretrain", cmd_pretrain), ("eval", cmd_eval),
                       ("build", cmd_build), ("bench", cmd_bench)):
        sub.choices[name].set_defaults(func=func)


def cmd_bench(args) -> int:
    ui_psa = args.what == "ui" and "psa" in (args.parts or "psa")  # bench ui --parts panel needs no backend
    if args.what in ("psa", "prompts") or ui_psa:
        from ..lapig_core.lgst import backend_class

        backend_class(args.backend)  # an unknown name is refused before any setup is rendered
    _ensure_registered()
    import importlib

    args.out = args.out or f"out/bench_{args.what}"
    module = importlib.import_module(f".bench.bench_{BENCHMARKS[args.what]}", __package__)
    summary = module.run(args)
    from .bench.machine_figure import machine_speed, with_machine_figures

    summary = with_machine_figures(summary, machine_speed())  # every benchmark's timings travel
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
    summary = syn.render_synthetic_setups(specs, args.out, args.train, args.test, args.seed,
                                          skip_existing=args.skip_existing, sheet=contact_sheet)
    print_json(summary)
    return 0


def cmd_pretrain(args) -> int:
    from . import pretrain

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
    keys = ("with_psa", "without_psa", "native", "style_retention", "surface_reach", "timings", "sheet")
    keys += ("with_refine",) if "with_refine" in summary else ()
    print_json({k: summary[k] for k in keys})
    return 0


def cmd_build(args) -> int:
    from . import bundle
    from .packaging import build_extension

    if args.lock:
        print(f"wrote {bundle.write_lock()}")
    if not args.platform:
        path = build_extension(os.path.abspath(args.out))
        print(f"built and validated {path}")
        print_json({"zips": [{"path": path, "platform": "any, without wheels",
                              "mb": round(os.path.getsize(path) / 2**20, 1)}]})
        return 0
    platforms = list(bundle.PLATFORM_TAGS) if "all" in args.platform else args.platform
    pythons = list(bundle.PYTHON_LINES) if args.python == "all" else [args.python]
    for platform in platforms:
        bundle.plan(platform, pythons[0], lock=[])  # unknown names refused before any download
    zips = []
    for platform in platforms:
        for python in pythons:
            print(f"building {platform} {python} (downloading its wheels once into {bundle.wheel_cache_root()})",
                  flush=True)
            built = bundle.build_platform_zip(platform, python, os.path.abspath(args.out))
            missing = f"; not bundled: {', '.join(built['not_bundled'])}" if built["not_bundled"] else ""
            print(f"built and validated {built['path']}: {built['mb']} MB, {built['wheels']} wheels, "
                  f"for {built['blender']}{missing}", flush=True)
            zips.append(built)
    print_json({"zips": zips})
    return 0
