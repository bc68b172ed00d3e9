"""The headless command line: `python -m lapig_addon CMD` or `blender -b -c lapig CMD`."""
from __future__ import annotations

import argparse
import sys


def _parser():
    parser = argparse.ArgumentParser(prog="python -m lapig_addon",
                                     description="LAPIG projector-image tools, headless.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def iterations_arg(p, default_text):
        p.add_argument("--iterations", type=int, default=None,
                       help=f"fine-tuning iterations per network (default: {default_text}); fewer: rough but quick")

    demo = sub.add_parser("demo", help="the whole pipeline on a demo scene: capture, train, stylize, render, export")
    demo.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    demo.add_argument("--shape", default="panel", choices=["panel", "box", "statue"])
    demo.add_argument("--surface", default="sakura")
    demo.add_argument("--train", type=int, default=125, help="training captures (default 125)")
    demo.add_argument("--test", type=int, default=4, help="test captures (default 4)")
    demo.add_argument("--prompt", default="Render it in the style of a Van Gogh oil painting")
    demo.add_argument("--seed", type=int, default=0)
    iterations_arg(demo, "the standard recipe")

    # settings a command does not get keep the scene's (its Capture, Stylize and Export panels)
    cap = sub.add_parser("capture", help="capture the scene's projector-camera setup into a data set")
    cap.add_argument("--blend", help=".blend file with a LAPIG rig (default: the open file)")
    cap.add_argument("--out", required=True, help="data set root folder")
    cap.add_argument("--setup", default=None, help="setup name (default: the surface object's name)")
    cap.add_argument("--train", type=int, help="training captures (default: the scene's)")
    cap.add_argument("--test", type=int, help="test captures (default: the scene's)")
    cap.add_argument("--size", type=int, help="working size (default: the scene's)")
    cap.add_argument("--samples", type=int, help="Cycles samples per capture (default: the scene's)")
    cap.add_argument("--patterns", help="folder of your own projector images (default: the scene's)")
    cap.add_argument("--seed", type=int, help="pattern seed (default: the scene's)")

    def blend_arg(p):
        p.add_argument("--blend", help=".blend file with a LAPIG rig (default: the open file)")
        p.add_argument("--save", action="store_true", help="save the .blend afterwards (keeps where you were)")

    tr = sub.add_parser("train", help="fine-tune CompenNeSt and PCNet on the scene's capture")
    blend_arg(tr)
    iterations_arg(tr, "the scene's")

    st = sub.add_parser("stylize", help="turn a prompt into a projector image for the scene's surface")
    blend_arg(st)
    st.add_argument("--prompt", required=True, help='e.g. "Make it a stained glass artwork"')
    st.add_argument("--backend", help="LGST backend, e.g. styletransfer (default: the scene's)")
    st.add_argument("--mix", help="explicit style mix instead of the prompt's, e.g. 'charcoal_wash:1'")
    st.add_argument("--seed", type=int, help="style seed (default: the scene's)")
    st.add_argument("--no-psa", dest="psa", action="store_false", default=None, help="skip the surface adaptation")
    st.add_argument("--strength", type=float, help="PSA strength in (0,1) (default: the scene's)")
    st.add_argument("--ip2p-model", help="InstructPix2Pix weights folder (default: the add-on preferences')")
    iterations_arg(st, "the scene's")
    st.add_argument("--render", action="store_true", help="also render the real capture with Cycles")

    ex = sub.add_parser("export", help="write the scene's projector image for a real projector")
    blend_arg(ex)
    ex.add_argument("--out", required=True, help="PNG path (a JSON sidecar is written beside it)")
    ex.add_argument("--bit-depth", type=int, choices=[8, 16], help="8 or 16 (default: the scene's)")
    ex.add_argument("--crossfade", help="also write a crossfade sequence (without -> with PSA) into this folder")
    ex.add_argument("--frames", type=int, help="crossfade frames (default: the scene's)")

    try:  # benchmarks, data sets, evaluation and packaging: only in a source checkout, not in the zip
        from ...tools import dev_commands
    except ImportError:
        dev_commands = None
    if dev_commands is not None:
        dev_commands.add_parsers(sub)
    return parser


def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        from ...lapig_core.common.deps import require

        require("numpy", "cv2")
        from . import commands

        return (args.func if hasattr(args, "func") else getattr(commands, "cmd_" + args.command))(args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (ValueError, OSError, ImportError) as exc:  # user-facing problems, no traceback
        print(f"error: {exc}", file=sys.stderr)
        return 1

