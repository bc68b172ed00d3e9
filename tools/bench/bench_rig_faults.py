"""`python -m lapig_addon bench rig-faults --json`: how often a capture on a camera that drops, repeats and
tears frames passes the real rig's calibration and health checks, and how its registration compares with
the clean run's, at 0 to 30 % of each fault (issue 35).

Each rate runs --setups seeds (the numpy fake projector and camera, 160x120 and 200x150, 50 ms latency with
10 ms jitter, on a virtual clock): a capture either passes, with its registration error's median, or stops
with a message; the messages are counted. At 30 % of each fault only one frame in ten is clean, and the
capture must stop saying the camera's frames cannot be verified (not misread them as auto exposure or a
crushed black, as it did before).
"""
from __future__ import annotations

import collections
import os
import shutil
import tempfile

from ...lapig_core.capture.fake_device import FakeDevice
from ...lapig_core.capture.sequence import GeometryChecks, run_capture
from ...lapig_core.capture.settings import CaptureError, CaptureSettings
from ...lapig_core.common.steps import run_to_end
from ...lapig_core.rig import RigError
from ...lapig_core.rig.simulated import CameraFaults, simulated_rig

RATES = (0.0, 0.05, 0.1, 0.2, 0.3)


def _capture(rate: float, seed: int, folder: str) -> dict:
    optics = FakeDevice(projector_size=(160, 120), camera_size=(200, 150), noise=0.003, seed=seed)
    faults = CameraFaults(latency_s=0.05, jitter_s=0.01, drop_rate=rate, repeat_rate=rate, torn_rate=rate)
    device, _, _ = simulated_rig(optics, faults, seed=seed)
    settings = CaptureSettings(out_dir=folder, setup_name="wall", train_count=4, test_count=1, working_size=32)
    checks = GeometryChecks(coverage=optics.coverage, exact_projector_to_camera=optics.exact_projector_to_camera)
    try:
        meta = run_to_end(run_capture(device, settings, checks))["meta"]
    except (RigError, CaptureError) as exc:
        return {"passed": False, "message": str(exc).split(":")[0]}
    return {"passed": True, "registration_px": meta["registration"]["registration_error_px_median"],
            "rejected": sum(meta["sync"].get("rejected", {}).values())}


def run(args) -> dict:
    seeds = max(1, args.setups)
    work = tempfile.mkdtemp(prefix="lapig_rig_faults_")
    rows, clean = {}, {}
    try:
        for rate in RATES:
            outcomes = [_capture(rate, seed, os.path.join(work, f"{rate}_{seed}")) for seed in range(seeds)]
            if rate == 0.0:
                clean = {seed: o.get("registration_px") for seed, o in enumerate(outcomes)}
            drift = [abs(o["registration_px"] - clean[seed]) for seed, o in enumerate(outcomes)
                     if o["passed"] and clean.get(seed) is not None]
            rows[f"{rate:.2f}"] = {
                "passed_share": round(sum(o["passed"] for o in outcomes) / seeds, 3),
                "registration_drift_px_max": round(max(drift), 4) if drift else None,
                "rejected_grabs_mean": round(sum(o.get("rejected", 0) for o in outcomes) / seeds, 1),
                "stopped_with": dict(collections.Counter(o["message"] for o in outcomes if not o["passed"]))}
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {"benchmark": "rig-faults", "seeds": seeds, "each_fault_rate": rows}
