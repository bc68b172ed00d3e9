"""Where a job's seconds went, phase by phase: Train reports it, so that a host where Train is slow says which
part is (the fine-tunes' steps, their setup, the classical fit, the choice, the rig's renders)."""
from __future__ import annotations

import time
from contextlib import contextmanager


class PhaseTimes(dict):
    """{phase name: seconds}, in the order the phases first ran; a phase timed twice adds up."""

    def add(self, name: str, seconds: float):
        self[name] = self.get(name, 0.0) + max(0.0, seconds)

    @contextmanager
    def timing(self, name: str):
        t = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t)

    def rounded(self) -> dict:
        return {name: round(seconds, 2) for name, seconds in self.items()}
