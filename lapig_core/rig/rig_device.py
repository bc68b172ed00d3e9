# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture device of a real projector output and a real camera (or simulated ones).

Before the first kept image (``lock_exposure``, which the capture sequence calls first) the rig:
1. locks what the camera lets it lock;
2. measures the display-to-capture latency (lapig_core.rig.sync.measure_latency);
3. finds the frame code's cells in the camera (lapig_core.rig.frame_code), so every later picture is
   verified;
4. runs the health checks (lapig_core.rig.health) and stops with their message if one fails.

Everything it measured is recorded in setup.json (``describe().details``). Its calls block (a camera's
grab, the waits), so it runs on a worker thread (main_thread False): Blender stays responsive.
"""
from __future__ import annotations

import numpy as np

from ..capture.device import CaptureDevice, DeviceInfo, GeometryChecks
from ..capture.settings import CaptureError
from ..common.imageio import to_uint8
from . import RigError
from . import frame_code as fc
from .clock import REAL_CLOCK
from .health import run_checks
from .still_pictures import FAULTY_SHARE, StillPictures
from .sync import FrameSync, measure_latency


class RigDevice(CaptureDevice):
    main_thread = False
    decode_twice = True  # a real camera: the sequence captures the finest stripes again and compares

    def __init__(self, output, camera, name: str = "real rig", clock=REAL_CLOCK, frame_code: bool = True,
                 health_checks: bool = True, settle_margin_s: float = 0.01, max_grabs: int = 8,
                 geometry: GeometryChecks | None = None):
        """geometry: the rig's ground truth, which only a simulated rig knows (None: none)."""
        self.output, self.camera, self.name, self.clock = output, camera, name, clock
        self.geometry = geometry or GeometryChecks()
        self.use_code, self.health_checks = frame_code, health_checks
        self.settle_margin_s = settle_margin_s
        self.layout = fc.CodeLayout.for_frame(*output.size)
        self.sync: FrameSync | None = None
        self.latency: dict = {}
        self.health: dict = {}
        self.code_state = "not measured"
        self.max_grabs = max_grabs
        self._shown = None

    # --- what the capture sequence asks
    def describe(self) -> DeviceInfo:
        latency = self.latency.get("latency_s", 0.0)
        settle = self.sync.settle_s if self.sync else 0.0
        sync = {"frame_code": self.code_state, **self.latency}
        if self.sync is not None:
            sync.update(self.sync.stats.as_dict(), settle_s=round(settle, 4))
        return DeviceInfo(self.name, tuple(self.output.size), tuple(self.camera.size),
                          {"projector": self.output.describe(), "camera": self.camera.describe(),
                           "sync": sync, **({"health": self.health} if self.health else {})},
                          frame_bit_depths=(8, 16), settle_s=round(settle, 4), latency_s=round(latency, 4))

    def geometry_checks(self) -> GeometryChecks:
        return self.geometry

    def reserved_rows(self) -> tuple[int, int]:
        return self.layout.reserved_rows() if self.sync is not None and self.sync.verifies else (0, 0)

    def lock_exposure(self, white_frame) -> None:
        """Calibrate the rig's timing and code, then check its health (see the module docstring)."""
        if self.sync is not None:
            return
        lock = getattr(self.camera, "lock", None)
        if lock is not None:
            lock()
        self.latency = measure_latency(self.output, self.camera, self.clock)
        settle = self.latency["latency_s"] + self.settle_margin_s
        cells = self._locate_cells(settle) if self.use_code else None
        self.sync = FrameSync(self.output, self.camera, self.clock, settle, cells, self.layout, self.max_grabs)
        if self.use_code:
            bands = cells.readable_bands()
            self.code_state = {2: "verified, top and bottom bands", 1: "verified, one band (tears go unseen)",
                               0: "not seen: timing only"}[len(bands)]
        else:
            self.code_state = "off: timing only"
        if self.health_checks:
            report = run_checks(self.sync.shoot, self.output.size, ignore=self._code_pixels(cells))
            self.health = report.as_dict()
            if not report.ok:
                raise CaptureError("the rig's health checks failed: " + "; ".join(report.problems))

    def show(self, frame) -> None:
        self.check_frame(frame)
        self._shown = frame

    def grab(self):
        return self.capture([self._shown])[0]

    def capture(self, frames) -> list[np.ndarray]:
        if self.sync is None:
            raise RigError("the rig shot a frame before its calibration (lock_exposure)")
        # the window shows 8 bits a channel (what HDMI carries from a desktop): a 16-bit frame is rounded
        return [self.sync.shoot(to_uint8(frame)) for frame in frames]

    def vary_noise(self, draw: int) -> None:
        """A real camera's noise is new every grab; a simulated one passes this on to its optics."""
        vary = getattr(self.camera, "vary_noise", None)
        if vary is not None:
            vary(draw)

    def close(self) -> None:
        try:
            self.camera.close()
        finally:
            self.output.close()

    # --- calibration
    @staticmethod
    def _code_pixels(cells: fc.CellMap | None):
        """Camera pixels near the code's cells (blur reaches past a cell's mask)."""
        if cells is None or not cells.masks:
            return None
        import cv2

        union = np.any(np.stack(list(cells.masks.values())), axis=0).astype(np.uint8)
        return cv2.dilate(union, np.ones((5, 5), np.uint8)).astype(bool)

    def _locate_cells(self, settle: float) -> fc.CellMap:
        """Show each code cell alone (after a black frame), with generous waits; nothing is verified yet,
        so each picture is one that several grabs agree on (rig.still_pictures). Where the code cannot be
        read in both bands and the grabs often agreed with nothing, the camera's frames cannot be verified,
        and the health checks would read faulty frames: stop and say so."""
        w, h = self.output.size
        stills = StillPictures(self.output, self.camera, self.clock, settle)
        black = stills.black(np.zeros((h, w, 3), np.uint8))
        lit = {key: stills.lit(fc.single_cell(self.layout, *key), black) for key in self.layout.cells()}
        cells = fc.locate_cells(black, lit)
        if len(cells.readable_bands()) < 2 and stills.faulty_share() > FAULTY_SHARE:
            raise RigError(stills.unverifiable())
        return cells
