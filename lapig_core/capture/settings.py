# SPDX-License-Identifier: GPL-3.0-or-later
"""What a capture is asked to do, and the error it refuses with."""
from __future__ import annotations

from dataclasses import dataclass, field


class CaptureError(ValueError):
    """A capture that cannot start or go on, with a message the user can act on."""


@dataclass
class CaptureSettings:
    out_dir: str
    setup_name: str = "setup"
    train_count: int = 32
    test_count: int = 8
    working_size: int = 256
    gray_level: float = 0.5
    samples: int = 1  # Cycles device only
    ambient: float = 0.03  # Cycles device only: room light, relative to the projector's white
    pattern_folder: str | None = None
    seed: int = 0
    chunk: int = 8  # frames per capture() call, and between two progress reports
    min_coverage: float = 0.3  # of the whole frame on the object: a statue leaves the corners free
    check_registration: bool = True
    check_grid_step: int = 4
    timings: dict = field(default_factory=dict)  # filled by the capture
