"""The headless command line: `python -m lapig_addon CMD` or `blender -b -c lapig CMD`."""
from __future__ import annotations

import argparse
import json
import sys


def _parser():
    parser = argparse.ArgumentParser(prog="python -m lapig_addon",
                                     description="LAPIG projector-image tools, headless.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    demo = sub.add_parser("demo", help="the whole pipeline on a demo scene: capture, train, stylize, render, export")
    demo.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    demo.add_argument("--shape", default="panel", choices=["panel", "box", "statue"])
    demo.add_argument("--surface", default="sakura")
    demo.add_argument("--train", type=int, default=125, help="training captures (default 125)")
    demo.add_argument("--test", type=int, default=4, help="test captures (default 4)")
    demo.add_argument("--prompt", default="Render it in the style of a Van Gogh oil painting")
    demo.add_argument("--seed", type=int, default=0)

    cap = sub.add_parser("capture", help="capture the scene's projector-camera setup into a data set")
    cap.add_argument("--blend", help=".blend file with a LAPIG rig (default: the open file)")
    cap.add_argument("--out", required=True, help="data set root folder")
    cap.add_argument("--setup", default=None, help="setup name (default: the surface object's name)")
    cap.add_argument("--train", type=int, default=32)
    cap.add_argument("--test", type=int, default=8)
    cap.add_argument("--size", type=int, default=256, help="working size (default 256)")
    cap.add_argument("--samples", type=int, default=1)
    cap.add_argument("--patterns", help="folder of your own projector images (default: generated)")
    cap.add_argument("--seed", type=int, default=0)

    data = sub.add_parser("dataset", help="render the synthetic setups used for pretraining and benchmarks")
    data.add_argument("--setups", default="pretrain",
                      help="'pretrain', 'bench', or comma-separated setup names (default: pretrain)")
    data.add_argument("--out", default="out/pretrain_data", help="data set root folder")
    data.add_argument("--train", type=int, default=125)
    data.add_argument("--test", type=int, default=20)
    data.add_argument("--seed", type=int, default=0, help="pattern seed")
    data.add_argument("--skip-existing", action="store_true", help="keep setups that are already complete")

    pre = sub.add_parser("pretrain", help="pretrain CompenNeSt, PCNet and CompenNeSt reversed on rendered setups")
    pre.add_argument("--data", default="out/pretrain_data", help="data set root from 'dataset'")
    pre.add_argument("--out", default="lapig_core/weights", help="folder for the weights")
    pre.add_argument("--iterations", type=int, default=2000)
    pre.add_argument("--crop", type=int, default=96, help="random crop size (default 96)")
    pre.add_argument("--only", choices=["compennest", "pcnet", "reversed"], action="append",
                     help="train only these networks (repeatable)")
    pre.add_argument("--seed", type=int, default=0)

    def blend_arg(p):
        p.add_argument("--blend", help=".blend file with a LAPIG rig (default: the open file)")
        p.add_argument("--save", action="store_true", help="save the .blend afterwards (keeps where you were)")

    tr = sub.add_parser("train", help="fine-tune CompenNeSt and PCNet on the scene's capture")
    blend_arg(tr)

    st = sub.add_parser("stylize", help="turn a prompt into a projector image for the scene's surface")
    blend_arg(st)
    st.add_argument("--prompt", required=True, help='e.g. "Make it a stained glass artwork"')
    st.add_argument("--backend", default="styletransfer", help="LGST backend (default: styletransfer)")
    st.add_argument("--mix", default="", help="explicit style mix instead of the prompt's, e.g. 'charcoal_wash:1'")
    st.add_argument("--seed", type=int, default=0)
    st.add_argument("--no-psa", dest="psa", action="store_false", help="skip the surface adaptation")
    st.add_argument("--strength", type=float, default=0.5, help="PSA strength in (0,1) (default 0.5)")
    st.add_argument("--render", action="store_true", help="also render the real capture with Cycles")

    ex = sub.add_parser("export", help="write the scene's projector image for a real projector")
    blend_arg(ex)
    ex.add_argument("--out", required=True, help="PNG path (a JSON sidecar is written beside it)")
    ex.add_argument("--bit-depth", type=int, choices=[8, 16], default=8)
    ex.add_argument("--crossfade", help="also write a crossfade sequence (without -> with PSA) into this folder")
    ex.add_argument("--frames", type=int, default=60, help="crossfade frames (default 60)")

    ev = sub.add_parser("eval", help="one surface image and prompt: stylize with and without PSA, capture both")
    ev.add_argument("--surface", required=True, help="surface texture image (PNG/JPG)")
    ev.add_argument("--prompt", required=True, help='e.g. "Make it a stained glass artwork"')
    ev.add_argument("--out", required=True, help="output folder (sheet.png, metrics.json)")
    ev.add_argument("--backend", default="styletransfer", help="LGST backend (default: styletransfer)")
    ev.add_argument("--seed", type=int, default=0)
    ev.add_argument("--train", type=int, default=125, help="captured training pairs (default 125)")
    ev.add_argument("--psa-iterations", type=int, default=30, help="PSA iteration cap (default 30)")
    ev.add_argument("--verbose", action="store_true", help="print training progress")

    build = sub.add_parser("build", help="build and validate the extension zip with Blender's extension CLI")
    build.add_argument("--out", default="dist", help="output folder (default: dist)")

    bench = sub.add_parser("bench", help="benchmarks that print one JSON object as their last line")
    bench.add_argument("what", choices=["capture", "models", "psa", "ui"], help="which benchmark")
    bench.add_argument("--json", action="store_true", help="print only the JSON summary at the end")
    bench.add_argument("--out", default=None, help="output folder (default: out/bench_WHAT)")
    bench.add_argument("--patterns", type=int, default=40, help="train+test captures to time (default 40)")
    bench.add_argument("--camera", default="480x360", help="capture resolution WxH (default 480x360)")
    bench.add_argument("--shape", default="panel", choices=["panel", "box", "statue"],
                       help="capture: demo object (default: panel, the demo scene)")
    bench.add_argument("--data", default="out/bench_data",
                       help="models: data set root of the benchmark setups (rendered when missing)")
    bench.add_argument("--setups", type=int, default=3, help="models: how many benchmark setups (default 3)")
    bench.add_argument("--iterations", type=int, default=None,
                       help="models: fine-tuning iterations per model (default: the CPU recipe's)")
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
    bench.add_argument("--backend", default="styletransfer", help="psa/ui: LGST backend")
    bench.add_argument("--train", type=int, default=125, help="psa: captured training pairs per surface")
    bench.add_argument("--psa-iterations", type=int, default=None, help="psa: PSA iteration cap (default 25)")
    bench.add_argument("--seed", type=int, default=0)
    return parser


def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        from ..lapig_core.deps import require

        require("numpy", "cv2")
        from . import commands

        return getattr(commands, "cmd_" + args.command)(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (ValueError, OSError, ImportError) as exc:  # user-facing problems, no traceback
        print(f"error: {exc}", file=sys.stderr)
        return 1


def print_json(summary: dict):
    print(json.dumps(summary, sort_keys=True), flush=True)
