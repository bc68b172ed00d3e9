# SPDX-License-Identifier: GPL-3.0-or-later
"""The device check's capture (tools/bench/fixtures/device_check/): the numpy fake rig captured through the
capture sequence, as the app captures, small enough to ship in the repository.

    python -m lapig_addon bench device --make-fixture     (rewrites it; then run the check on the CPU again
                                                           with --write-cpu-figures: the figures belong to it)

Only what Train, PSA and the native output read is kept: the projector images, the registered captures, the
raw references and the registration. The raw captures of the training, test and Gray-code patterns (three
quarters of the bytes) are left out.
"""
from __future__ import annotations

import shutil
from pathlib import Path

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "device_check"
SETUP = "device_check"
PROJECTOR, CAMERA = (160, 120), (240, 180)  # 4:3, the working frame 128 x 96
WORKING_SIZE, TRAIN, TEST = 128, 48, 8  # the paper's 48-image budget; 8 held back for the choice
PRUNED = ("cam/raw/train", "cam/raw/test", "cam/raw/sl")


def make_fixture(root=FIXTURE, working_size: int = WORKING_SIZE, train: int = TRAIN, test: int = TEST,
                 seed: int = 0, projector=PROJECTOR, camera=CAMERA) -> Path:
    """Capture the fake rig into `root` (replaced) and prune it; returns the setup's folder (projector, camera:
    other sizes, as bench looks' slider figure takes an 800 x 600 projector)."""
    from ...lapig_core.capture.fake_device import FakeDevice
    from ...lapig_core.capture.sequence import GeometryChecks, run_capture
    from ...lapig_core.capture.settings import CaptureSettings

    root = Path(root)
    if root.exists():
        shutil.rmtree(root)
    device = FakeDevice(projector_size=tuple(projector), camera_size=tuple(camera), seed=seed)
    settings = CaptureSettings(out_dir=str(root), setup_name=SETUP, train_count=train, test_count=test,
                               working_size=working_size, chunk=8, seed=seed)
    checks = GeometryChecks(coverage=device.coverage, exact_projector_to_camera=device.exact_projector_to_camera)
    steps = run_capture(device, settings, checks)
    try:
        while True:
            next(steps)
    except StopIteration as done:
        setup_dir = Path(done.value["setup_dir"])
    for folder in PRUNED:
        shutil.rmtree(setup_dir / folder, ignore_errors=True)
    return setup_dir
