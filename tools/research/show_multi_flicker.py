"""Where a show of several projectors flickers (BENCHMARKS "A show on several projectors"): the moving look's
frames through the joint model's drives (no resampling), through the projectors' frames (camera -> projector -> camera),
and captured on the fake rig, for three weights of the joint solve's pull towards the blend's split.
Run: .venv/bin/python tools/research/show_multi_flicker.py"""
import importlib.util, sys, os, tempfile, pathlib
import numpy as np
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.tools.bench import bench_show_multi as B
from lapig.tools.fakes import fake_rig
from lapig.lapig_core.show.joint_setup import JointShowSetup
from lapig.lapig_core.show.frames import FrameMaker
from lapig.lapig_core.show.model import Look, Motion, Show, Transition
from lapig.lapig_core.multi.joint_solve import joint_drives
rig = fake_rig.side_by_side_rig(B.CAMERA, B.PROJECTOR, noise=0.0)
tmp = tempfile.mkdtemp()
sd = B._capture(rig, os.path.join(tmp, "d"))
folders = B._looks(sd, os.path.join(tmp, "r"), 10, 256)
setup = JointShowSetup.from_capture(sd, working_size=256, gammas=[p.gamma for p in rig.projectors])
b = Look(folders[1], B.LOOKS[1], "styletransfer", 0, hold_s=2.0, motion=Motion("drift", 0.6, 2.0))
a = Look(folders[0], B.LOOKS[0], "styletransfer", 0, hold_s=0.3)
show = Show([a, b], [Transition("morph", 1.0)], fps=10)
maker = FrameMaker(show, setup)
keys = list(dict.fromkeys(maker.schedule.at(i) for i in range(maker.schedule.total_frames)))
moving = [k for k in keys if k[0] == "moving"][:12]
for k in keys:
    if k[0] != "moving": maker.frame(k)
targets = [maker.target_of(k)[0].permute(1,2,0).numpy() for k in moving]
mask = setup.on
m = setup.model
for lam in (1e-3, 1e-2, 1e-1):
    drives = [joint_drives(m, np.where(setup.reached[...,None], t, setup.surface).astype(np.float32), setup.weights, lam) for t in targets]
    lin = [m.predict_linear(d) for d in drives]
    from lapig.lapig_core.multi.joint_solve import projector_frames
    res = [m.predict(projector_frames(m, d)) for d in drives]
    cap = [rig.capture(projector_frames(m, d)).astype(np.float32)/255 for d in drives]
    print(lam, "drives", round(B._flicker(lin, targets, mask),3), "frames", round(B._flicker(res, targets, mask),3), "captured", round(B._flicker(cap, targets, mask),3))
