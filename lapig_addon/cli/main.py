"""The headless command line: `python -m lapig_addon CMD` or `blender -b -c lapig CMD`."""
from __future__ import annotations

import argparse
import os
import sys
import traceback

from ..services.errors import one_line
from .interrupt import exit_interrupted
from .options import check_ranges, ranged_option


def _parser():
    parser = argparse.ArgumentParser(prog="python -m lapig_addon",
                                     description="LAPIG projector-image tools, headless.")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def iterations_arg(p, default_text):
        ranged_option(p, "--iterations", "finetune_iterations",
                      f"fine-tuning iterations per network (default: {default_text}); fewer: rough but quick")

    def device_arg(p):
        # the names of lapig_core/common/compute_device.CHOICES (not imported: it imports torch)
        p.add_argument("--device", choices=["auto", "cpu"], default=None,
                       help="where torch runs: auto (a GPU where torch can use one: CUDA, then Apple's MPS; else "
                            "the CPU) or cpu (default: the add-on preferences', auto)")

    demo = sub.add_parser("demo", help="the whole pipeline on a demo scene: capture, train, stylize, render, export")
    demo.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    demo.add_argument("--shape", default="panel", choices=["panel", "box", "statue"])
    demo.add_argument("--surface", default="sakura")
    ranged_option(demo, "--train", "train_count", "training captures (default 125)", default=125)
    ranged_option(demo, "--test", "test_count", "test captures (default 4)", default=4)
    demo.add_argument("--prompt", default="Render it in the style of a Van Gogh oil painting")
    ranged_option(demo, "--seed", "seed", "pattern and style seed", default=0)
    iterations_arg(demo, "the standard recipe")
    device_arg(demo)

    def blend_arg(p):
        p.add_argument("--blend", help=".blend file with a LAPIG rig (default: the open file)")
        p.add_argument("--save", action="store_true", help="save the .blend afterwards (keeps where you were)")

    def capture_arg(p):
        p.add_argument("--capture", metavar="DIR",
                       help="the capture to use: a setup folder (<root>/setups/<name>) this rig made (default: "
                            "the .blend's; --save then records this one in it)")

    def rig_args(p):
        g = p.add_argument_group("rig", "the projector and camera (default: the scene's: its virtual rig, or "
                                        "the real one a capture --rig real --save recorded)")
        g.add_argument("--rig", choices=["virtual", "real", "simulated"],
                       help="virtual: the Cycles studio; real: a projector window on --display and --camera; "
                            "simulated: the Cycles studio behind a real rig's timing and faults (no hardware)")
        g.add_argument("--display", help="real: the projector's display, an index or a part of its name "
                                         "(see 'devices')")
        g.add_argument("--camera", dest="camera_source",
                       help="real: a camera index, a stream URL or a video file (see 'devices')")
        g.add_argument("--camera-backend", default=None,
                       help="real: auto (V4L2 / DirectShow / AVFoundation), v4l2, dshow, msmf, avfoundation, ffmpeg")
        g.add_argument("--tethered", metavar="DIR", help="real: a folder a tethering program saves each picture into")
        for name in ("exposure", "gain", "focus", "white-balance"):
            g.add_argument(f"--{name}", type=float, help=f"real: lock the camera's {name.replace('-', ' ')} "
                                                         "(the backend's units; default: locked where it is)")
        g.add_argument("--rig-name", help="real: the rig's name, recorded with its captures")
        g.add_argument("--no-frame-code", dest="frame_code", action="store_false", default=None,
                       help="real: sync by the measured latency alone (no code at the frame's edges)")
        g.add_argument("--sim-latency", type=float, default=0.1, help="simulated: camera latency in seconds")
        g.add_argument("--sim-faults", type=float, default=0.03,
                       help="simulated: share of dropped, of repeated and of torn frames, each")
        g.add_argument("--sim-display-gone", type=int, default=None, metavar="N",
                       help="simulated, several projectors: the last projector's display goes after N frames, as "
                            "an unplugged display does")

    # settings a command does not get keep the scene's (its Capture, Stylize and Export panels)
    cap = sub.add_parser("capture", help="capture the scene's projector-camera setup into a data set "
                                         "(--save records it in the .blend, as the panel does)")
    blend_arg(cap)
    cap.add_argument("--out", help="data set root folder (default: the .blend's data folder, as the panel's)")
    cap.add_argument("--setup", default=None, help="setup name (default: the surface object's name)")
    ranged_option(cap, "--train", "train_count", "training captures (default: the scene's)")
    ranged_option(cap, "--test", "test_count", "test captures (default: the scene's)")
    ranged_option(cap, "--size", "working_size", "working size (default: the scene's)")
    ranged_option(cap, "--samples", "samples", "Cycles samples per capture (default: the scene's)")
    cap.add_argument("--patterns", help="folder of your own projector images (default: the scene's)")
    ranged_option(cap, "--seed", "seed", "pattern seed (default: the scene's)")

    rig_args(cap)

    tr = sub.add_parser("train", help="fine-tune CompenNeSt and PCNet on the scene's capture")
    blend_arg(tr)
    capture_arg(tr)
    rig_args(tr)
    iterations_arg(tr, "the scene's")
    device_arg(tr)

    st = sub.add_parser("stylize", help="turn a prompt into a projector image for the scene's surface")
    blend_arg(st)
    capture_arg(st)
    st.add_argument("--prompt", help='e.g. "Make it a stained glass artwork" (required unless --style-image)')
    st.add_argument("--backend", help="LGST backend, e.g. styletransfer (default: the scene's)")
    st.add_argument("--mix", help="explicit style mix instead of the prompt's, e.g. 'charcoal_wash:1'")
    st.add_argument("--style-image", dest="style_images", action="append", metavar="PATH[:WEIGHT]",
                    help="take the look's style from this painting or photo (the 'arbitrary' backend); "
                         "repeat to mix several, e.g. --style-image a.jpg:0.7 --style-image b.png:0.3 "
                         "(default: the scene's style image, if any)")
    ranged_option(st, "--style-prompt-weight", "style_prompt_weight",
                  "share of the prompt's own look mixed into the style images' (default: the scene's)", type=float)
    ranged_option(st, "--seed", "style_seed", "style seed (default: the scene's)")
    st.add_argument("--no-psa", dest="psa", action="store_false", default=None, help="skip the surface adaptation")
    ranged_option(st, "--adaptation", "psa_adaptation",
                  "PSA adaptation, 0 keep my look .. 1 whatever this surface can show (default: the scene's)",
                  type=float)
    st.add_argument("--ip2p-model", help="InstructPix2Pix weights folder (default: the add-on preferences')")
    st.add_argument("--depth-model", help="the depth adapter's folder: InstructPix2Pix follows the object's depth "
                                          "(default: the model manager's, where it is ready)")
    st.add_argument("--one-step-model", help="the one-step model's folder for --backend one-step (default: the "
                                             "model manager's, where it is ready)")
    ranged_option(st, "--output-size", "output_size",
                  "long side of the final projector image, 0 for the projector's native frame (default: the "
                  "scene's)")
    outside = st.add_mutually_exclusive_group()
    outside.add_argument("--dark-outside", dest="dark_outside", action="store_true", default=None,
                         help="black projector pixels where the frame misses the object (default: the scene's)")
    outside.add_argument("--light-outside", dest="dark_outside", action="store_false",
                         help="project the look over the whole frame, off the object too")
    iterations_arg(st, "the scene's")
    ranged_option(st, "--refine", "refine_iterations",
                  "refine the projector image on the rig: project, capture, correct, at most N steps (default 0: "
                  "open loop only)", default=0)
    st.add_argument("--render", action="store_true", help="also render the real capture with Cycles")
    device_arg(st)
    rig_args(st)

    ex = sub.add_parser("export", help="write the scene's projector image for a real projector")
    blend_arg(ex)
    ex.add_argument("--out", required=True, help="PNG path (a JSON sidecar is written beside it)")
    ex.add_argument("--result", help="result folder to export, e.g. one stylize made without --save "
                                     "(default: the scene's result)")
    ex.add_argument("--bit-depth", type=int, choices=[8, 16], help="8 or 16 (default: the scene's)")
    ex.add_argument("--crossfade", help="also write a crossfade sequence (without -> with PSA) into this folder")
    ex.add_argument("--mpcdi-version", choices=["2.0", "1.0"], default="2.0",
                    help="the MPCDI package's version: 2.0 (Watchout 7, nDisplay, Pixera; default) or 1.0 (Watchout 6, "
                         "the VESA reference reader, which refuses 2.0)")
    ex.add_argument("--mpcdi", help="also write the rig's MPCDI package (--mpcdi-version; '2d' profile: each "
                                    "projector's warp and blend) to this .mpcdi file; a rig of several projectors "
                                    "writes one image per projector, <out>_1.png, <out>_2.png, ...")
    ex.add_argument("--profile", choices=["2d", "sl"], default="2d",
                    help="the MPCDI profile: '2d' (Watchout, BrightSign; default) or 'sl' (shader lamp: nDisplay, "
                         "TouchDesigner: each projector's pose, frustum and 3D surface point per 8th pixel)")
    ranged_option(ex, "--frames", "crossfade_frames", "crossfade frames (default: the scene's)")

    sh = sub.add_parser("show", help="play the scene's look live on the projector (Esc in the window stops)")
    blend_arg(sh)
    sh.add_argument("--display", help="the projector's display (default: the scene's real rig's); a rig of several: "
                                      "one each, comma-separated, e.g. 1,2 (default: each projector's own)")
    sh.add_argument("--lock-frames", type=int, default=30,
                    help="several projectors: present the look this many times at --fps and report the windows' "
                         "lock (max_skew_frames; default 30, 0: none)")
    sh.add_argument("--result", help="result folder to show (default: the scene's result)")
    sh.add_argument("--seconds", type=float, default=None,
                    help="close after this long (default: stay until Esc in the window)")
    sh.add_argument("--crossfade", action="store_true", help="first fade from the look without PSA to the look")
    sh.add_argument("--fps", type=float, default=30.0, help="crossfade frame rate (default 30)")
    ranged_option(sh, "--frames", "crossfade_frames", "crossfade frames (default: the scene's)")
    sh.add_argument("--timeline", action="store_true",
                    help="play the scene's show (its looks on the timeline) at the scene's frame rate, its frames made "
                         "ahead; prints the late frames")

    se = sub.add_parser("show-export", help="export the scene's show per projector: a video (or a PNG sequence) "
                                            "and a JSON sidecar of its looks, times, transitions and frame rate")
    se.add_argument("--blend", help=".blend file with a LAPIG rig and a show (default: the open file)")
    se.add_argument("--out", required=True, help="the folder to write into (show.mp4 or show_1.mp4, show_2.mp4, "
                                                 "...; show.json)")
    se.add_argument("--codec", default="h264", type=str.lower, help=_codec_help())
    se.add_argument("--ffmpeg", help="a system ffmpeg for the codecs the installed PyAV lacks (HAP; default: "
                                     "$LAPIG_FFMPEG, then the ffmpeg on PATH)")
    se.add_argument("--bit-depth", type=int, choices=[8, 16], help="8 or 16 (default: the scene's export bit depth)")
    se.set_defaults(func=_show_export)

    sub.add_parser("devices", help="list the displays a projector window can open on, and the cameras")

    from . import report_command

    report_command.add_parser(sub)

    try:  # benchmarks, data sets, evaluation and packaging: only in a source checkout, not in the zip
        from ...tools import dev_commands
    except ImportError:
        dev_commands = None
    if dev_commands is not None:
        dev_commands.add_parsers(sub)
    for command in sub.choices.values():  # --debug after the command name too
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    return parser


def _codec_help() -> str:
    """--codec's help: every choice with its trade-off (lapig_core/export/codecs, no av import)."""
    from ...lapig_core.export.codecs import CODECS

    choices = "; ".join(f"{c.name}: {c.help}" for c in CODECS.values())
    return (f"{choices}; png: a folder of PNGs per projector (8 or 16 bit, exact, the largest). Default h264. "
            f"HAP where PyAV or a system FFmpeg has its encoder")


def _show_export(args) -> int:
    """show-export: the codec is checked before the .blend opens (services/show/show_source, no bpy)."""
    from ...lapig_core.export.codecs import FFMPEG_ENV
    from ..services.show.show_source import codec_problem

    args.codec = args.codec.lower()
    if getattr(args, "ffmpeg", None):  # the video writer reads it on the worker thread
        os.environ[FFMPEG_ENV] = os.path.abspath(args.ffmpeg) if os.sep in args.ffmpeg else args.ffmpeg
    problem = codec_problem(args.codec)
    if problem:
        raise ValueError(problem)
    from . import commands

    return commands.cmd_show_export(args)


def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        check_ranges(args)  # before a .blend is opened or anything allocated
        from ...lapig_core.common.deps import require

        require("numpy", "cv2")
        from . import commands

        return (args.func if hasattr(args, "func") else getattr(commands, "cmd_" + args.command))(args)
    except KeyboardInterrupt:  # the jobs have stopped their worker threads on the way out
        return exit_interrupted()
    except Exception as exc:  # the one error boundary: one line with the cause, exit status 1
        if args.debug:
            traceback.print_exc()
        print(f"error: {one_line(exc)}", file=sys.stderr)
        return 1

