"""The headless commands' --rig options: which projector and camera a command captures or judges with.

--rig real records the real rig in the scene (saved with --save), as the panel does, so a later train
or stylize on the same .blend uses it without the options again; --rig virtual goes back to the Cycles
studio; --rig simulated wraps the Cycles studio in a real rig's timing and faults for this command only.
"""
from __future__ import annotations

import dataclasses

from ..blender import scene_state

CAMERA_OPTIONS = {"exposure": "exposure", "gain": "gain", "focus": "focus", "white_balance": "white_balance"}


def apply(args, scene):
    """The device factory this command runs against (None: the scene's own, after recording a --rig real
    or --rig virtual in it)."""
    kind = getattr(args, "rig", None)
    if kind is None:
        if _real_options_given(args):
            raise ValueError("--display, --camera and the camera settings go with --rig real")
        return None
    if kind == "virtual":
        scene_state.record_real_rig(scene, None)
        return None
    if kind == "simulated":
        return _simulated(args, scene)
    scene_state.record_real_rig(scene, real_spec(args, scene_state.real_rig_spec(scene)))
    return None


def real_spec(args, current=None):
    """The RigSpec of the --rig real options over the scene's current one (None: the defaults)."""
    from ..rigs.real_rig import RigSpec

    spec = current or RigSpec()
    changes = {}
    if args.display is not None:
        changes["display"] = args.display
    if args.camera_source is not None:
        changes.update(camera=args.camera_source, tethered_folder="")
    if args.tethered is not None:
        changes["tethered_folder"] = args.tethered
    if args.camera_backend is not None:
        changes["camera_backend"] = args.camera_backend
    if args.rig_name:
        changes["name"] = args.rig_name
    if args.frame_code is not None:
        changes["frame_code"] = args.frame_code
    settings = dict(spec.camera_settings)
    settings.update({key: getattr(args, attr) for key, attr in CAMERA_OPTIONS.items()
                     if getattr(args, attr, None) is not None})
    changes["camera_settings"] = settings
    spec = dataclasses.replace(spec, **changes)
    if (current is None and (args.display is None or (args.camera_source is None and args.tethered is None))) \
            or spec.problem():  # the scene's real rig had no display or camera chosen either
        raise ValueError("--rig real needs --display and --camera (or --tethered DIR): 'devices' lists them")
    return spec


def _real_options_given(args) -> bool:
    return any(getattr(args, name, None) is not None
               for name in ("display", "camera_source", "tethered", "camera_backend", *CAMERA_OPTIONS.values()))


def _simulated(args, scene):
    from ...lapig_core.rig.clock import VirtualClock
    from ...lapig_core.rig.simulated import CameraFaults
    from ..blender.cycles_factory import CyclesDeviceFactory
    from ..rigs.real_rig import SimulatedRigFactory
    from ..services.state import JOINT

    rate = args.sim_faults
    if not (0 <= rate <= 0.3) or not (0 <= args.sim_latency <= 2):
        raise ValueError("--sim-faults must lie within 0..0.3 and --sim-latency within 0..2 s")
    faults = CameraFaults(latency_s=args.sim_latency, jitter_s=args.sim_latency / 5, drop_rate=rate,
                          repeat_rate=rate, torn_rate=rate)
    rig = scene_state.read_rig(scene)
    gone = getattr(args, "sim_display_gone", None)
    if gone is not None and (gone < 1 or rig.strategy != JOINT):  # a display gone mid-capture: the joint rig's
        raise ValueError("--sim-display-gone takes a number of frames, and a rig of several projectors")
    closes_after = [None] * (rig.projector_count - 1) + [gone] if gone is not None else None
    return SimulatedRigFactory(CyclesDeviceFactory(scene), faults, clock=VirtualClock(),
                               names=list(rig.projectors),
                               closes_after=closes_after)
