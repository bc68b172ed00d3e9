# SPDX-License-Identifier: GPL-3.0-or-later
"""The first look: the capture's classical model, fitted when the capture ends, so that Generate works at once.

Fine-tuning the networks takes minutes on a CPU; the per-pixel classical model (photometric/classical) fits in
seconds and compensated best on four of the five realistic setups and on the demo wall (BENCHMARKS, "Train
chooses the compensator by rendering both"). Until Train has run, Generate compensates with it and PSA runs its
losses through its forward direction (classical_compensator.ClassicalSimulator) as the simulator. Train reuses
the fitted model (it is the same fit), measures the networks against it, and says by how much the first look
is behind or ahead.

Files, beside the networks in the setup's models/ folder: classical.npz (the model; Train's choice uses the same
file) and first_look.json (which capture it belongs to, and how long it took), each written whole or not at all.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from ..common.atomic import atomic_write_bytes
from .model_names import CLASSICAL, CLASSICAL_FILE, LEARNED
from .classical import ClassicalModel

FIRST_LOOK_FILE = "first_look.json"
FIRST_LOOK_LINE = "first look: classical model; Train for the networks"


@dataclass(frozen=True)
class FirstLook:
    classical: ClassicalModel
    fingerprint: str
    fit_seconds: float

    def status_line(self) -> str:
        """The models step's line in the panel before Train."""
        return f"First look: classical model (fitted in {self.fit_seconds:.1f} s); Train for the networks"


def models_dir(setup_dir) -> Path:
    return Path(setup_dir) / "models"


def fit_first_look(cs, setup_dir) -> FirstLook:
    """Fit the capture's classical model on all its training pairs and save it as its first look."""
    t0 = time.perf_counter()
    classical = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    look = FirstLook(classical, cs.meta.get("fingerprint") or "", time.perf_counter() - t0)
    save_first_look(setup_dir, look)
    return look


def save_first_look(setup_dir, look: FirstLook) -> None:
    folder = models_dir(setup_dir)
    folder.mkdir(parents=True, exist_ok=True)
    look.classical.save(folder / CLASSICAL_FILE)  # the record last: without it the model is no first look
    record = {"fingerprint": look.fingerprint, "fit_seconds": round(look.fit_seconds, 3),
              "residual_rms": round(float(look.classical.residual), 6), "gamma_c": look.classical.gamma_c,
              "gamma_p": look.classical.gamma_p}
    atomic_write_bytes(folder / FIRST_LOOK_FILE, json.dumps(record, indent=2).encode("utf-8"))


def load_first_look(setup_dir, fingerprint: str | None) -> FirstLook | None:
    """The capture's first look, or None: none fitted, fitted for another capture (its fingerprint), or a file
    that cannot be read (then Generate trains the networks as before)."""
    folder = models_dir(setup_dir)
    try:
        record = json.loads((folder / FIRST_LOOK_FILE).read_text())
        if (record.get("fingerprint") or "") != (fingerprint or ""):
            return None
        classical = ClassicalModel.load(folder / CLASSICAL_FILE)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return FirstLook(classical, record.get("fingerprint") or "", float(record.get("fit_seconds") or 0.0))


def first_look_record() -> dict:
    """result.json's `models` for a look made with the first look."""
    return {"first_look": True, "compensator": CLASSICAL, "simulator": CLASSICAL, "line": FIRST_LOOK_LINE}


def trained_record(choice, simulator: str = "PCNet") -> dict:
    """result.json's `models` for a look made with Train's models: which compensated, and how far the networks
    are ahead of the first look's classical model (negative: behind it), where Train measured it."""
    record = {"first_look": False, "compensator": choice.chosen if choice is not None else LEARNED,
              "simulator": simulator}
    ahead = networks_ahead_db(choice)
    if ahead is not None:
        record["networks_ahead_of_first_look_db"] = round(ahead, 3)
    record["line"] = f"Train's models: compensated by {record['compensator']}, simulated by {simulator}"
    return record


def networks_ahead_db(choice) -> float | None:
    """CompenNeSt's lead over the classical model in Train's measurement (None: not measured)."""
    if choice is None or choice.learned_psnr is None or choice.classical_psnr is None:
        return None
    return float(choice.learned_psnr) - float(choice.classical_psnr)


def after_train_note(choice) -> str:
    """What Train's measurement means for a first look the artist may be looking at."""
    ahead = networks_ahead_db(choice)
    if ahead is None:
        return ""
    if choice.chosen == LEARNED:
        return f"the networks are {ahead:.2f} dB ahead of the first look: Generate again to use them"
    if ahead <= 0:
        return f"the first look's classical model stays the compensator ({-ahead:.2f} dB ahead of CompenNeSt)"
    return (f"the first look's classical model stays the compensator (CompenNeSt only {ahead:.2f} dB ahead, "
            f"less than the lead it needs)")
