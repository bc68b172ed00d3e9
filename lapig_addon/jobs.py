"""The job engine: long work as a generator of progress steps, driven one step at a time.

The same object runs to completion in headless runs and tests, and is stepped by a modal
operator's timer inside Blender's UI (bpy.app.timers never fire in the bpy module). Cancelling
closes the generator, so its `with`/`finally` blocks undo whatever it had changed.
"""
from __future__ import annotations

import time
from typing import Callable, Iterator


class JobCancelled(Exception):
    pass


class Job:
    title = "LAPIG job"

    def __init__(self):
        self.progress = 0.0
        self.message = "waiting"
        self.state = "PENDING"  # PENDING, RUNNING, DONE, CANCELLED, FAILED
        self.error: BaseException | None = None
        self.result = None
        self._gen: Iterator | None = None
        self.started_at = None
        self.finished_at = None

    def steps(self) -> Iterator[tuple[float, str]]:
        """Yield (progress 0..1, message) between chunks of work; set self.result at the end."""
        raise NotImplementedError

    @property
    def finished(self) -> bool:
        return self.state in {"DONE", "CANCELLED", "FAILED"}

    def step(self) -> bool:
        """Advance by one chunk; returns True while there is more to do."""
        if self.finished:
            return False
        if self._gen is None:
            self.state, self.started_at = "RUNNING", time.perf_counter()
            self._gen = self.steps()
        try:
            self.progress, self.message = next(self._gen)
        except StopIteration:
            self._finish("DONE", 1.0, "done")
        except JobCancelled:
            self._finish("CANCELLED", self.progress, "cancelled")
        except Exception as exc:  # reported to the user by the operator or the CLI
            self.error = exc
            self._finish("FAILED", self.progress, str(exc))
        return not self.finished

    def cancel(self):
        if self.finished:
            return
        if self._gen is not None:
            self._gen.close()  # runs the generator's cleanup at its current yield
        self._finish("CANCELLED", self.progress, "cancelled")

    def _finish(self, state, progress, message):
        self.state, self.progress, self.message = state, progress, message
        self.finished_at = time.perf_counter()

    def run(self, on_progress: Callable[[float, str], None] | None = None,
            should_cancel: Callable[[], bool] | None = None) -> str:
        """Step until finished; returns the final state (failures stay in self.error)."""
        while self.step():
            if on_progress:
                on_progress(self.progress, self.message)
            if should_cancel and should_cancel():
                self.cancel()
        if on_progress:
            on_progress(self.progress, self.message)
        return self.state

    def run_to_completion(self, on_progress: Callable[[float, str], None] | None = None,
                          should_cancel: Callable[[], bool] | None = None):
        """Like run(), but a failure raises its exception; returns the job's result."""
        if self.run(on_progress, should_cancel) == "FAILED":
            raise self.error
        return self.result

    @property
    def elapsed(self) -> float:
        if self.started_at is None:
            return 0.0
        return (self.finished_at or time.perf_counter()) - self.started_at
