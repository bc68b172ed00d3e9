"""The session's two job slots: the artist's job in the foreground, one Train in the background.

Train starts in the background after a Capture made in Blender's UI (train_after_capture), so the
networks and the rendered choice come while the artist works with the first look. The background job
gives way: a foreground job (Generate, Preview's renders, Export's jobs...) pauses it and steps only once
it has let go of its locks and devices (foreground_may_step), and it resumes when the foreground job ends.
Until then the foreground job waits and says so, however long the background job's step takes; one that
reaches no pause point in STUCK_S is stuck, and the foreground job fails saying what to do.
Whatever replaces the capture or the models (a new Capture, Train pressed) cancels it first.
No bpy: blender/modal_runner holds one JobSlots and steps it from the operators' timers.
"""
from __future__ import annotations

import time

from .jobs import Job

BUSY = "Another LAPIG job is running: wait for it or press Esc"
WAITING_FOR_PAUSE = "waiting for the training in the background to pause"


class BackgroundJobStuck(ValueError):  # a ValueError: its message is worded for the artist (errors.one_line)
    """The background job reached no pause point in JobSlots.STUCK_S: it still holds its locks and devices."""


class JobSlots:
    # a background job that reaches no pause point by then is stuck: going first anyway would fail on its lock
    STUCK_S = 300.0

    def __init__(self):
        self.foreground: Job | None = None
        self.background: Job | None = None
        self.outcome: str | None = None  # how the last background job ended, for the panel (None: nothing to say)
        self._waiting_since = 0.0  # when the foreground job began to wait for the pause

    # -- the foreground -------------------------------------------------------------------------------
    def foreground_running(self) -> bool:
        return self.foreground is not None and not self.foreground.finished

    def start_foreground(self, job: Job) -> str | None:
        """Take the foreground slot (the background job is asked to pause); why not, or None."""
        if self.foreground_running():
            return BUSY
        self.foreground, self._waiting_since = job, time.monotonic()
        if self.background_running():
            self.background.pause()
        return None

    def busy_note(self) -> str:
        """Why a job's button is off while a foreground job runs ('' when none runs): the slot holds one job and
        queues none, so a second would only be refused."""
        if not self.foreground_running():
            return ""
        return (f"Off while {self.foreground.title} runs: LAPIG runs one job at a time and does not queue another "
                "(wait for it, or press Esc to cancel it)")

    def foreground_may_step(self) -> bool:
        """True once no background job holds the cores, a lock or a device; until then the background job
        is stepped here (a job's main-thread part reaches its pause point only when stepped)."""
        bg = self.background
        if bg is None or bg.finished or bg.paused:
            return True
        bg.pause()
        bg.step()
        if bg.finished or bg.paused:
            return True
        if self.foreground_running():
            self._wait_for_pause()
        return False

    def _wait_for_pause(self):
        """The foreground job says it waits; after STUCK_S it fails, saying what to do."""
        waited = time.monotonic() - self._waiting_since
        if waited <= self.STUCK_S:
            self.foreground.message = WAITING_FOR_PAUSE
            return
        self.foreground.fail(BackgroundJobStuck(
            f"the training in the background did not pause in {waited:.0f} s and still holds the capture: "
            f"Cancel it in the Models panel, then start {self.foreground.title} again"))

    def end_foreground(self, job: Job):
        """The foreground job ended: the background job goes on."""
        if self.foreground is job:
            self.foreground = None
        self.resume_background()

    def resume_background(self):
        """The background job goes on, unless a foreground job runs."""
        if self.background_running() and not self.foreground_running():
            self.background.resume()

    def pause_background_until_paused(self, timeout_s: float = 60.0, poll_s: float = 0.05) -> bool:
        """A synchronous run in the UI (a script calling an operator): wait here for the pause; True when
        paused (or none runs)."""
        deadline = time.monotonic() + timeout_s
        while not self.foreground_may_step():
            if time.monotonic() > deadline:
                return False
            time.sleep(poll_s)
        return True

    # -- the background ------------------------------------------------------------------------------
    def background_running(self) -> bool:
        return self.background is not None and not self.background.finished

    def start_background(self, job: Job) -> bool:
        """Take the background slot; False (and nothing started) while a background job runs."""
        if self.background_running():
            return False
        self.background, self.outcome = job, None
        if self.foreground_running():
            job.pause()
        return True

    def step_background(self) -> bool:
        """One step of the background job, unless a foreground job runs (then it stays paused); True while
        it has more to do."""
        bg = self.background
        if bg is None or bg.finished:
            return False
        if self.foreground_running():
            self.foreground_may_step()  # reaches its pause point, or stays there
            return not bg.finished
        bg.resume()
        return bg.step()

    def cancel_background(self) -> bool:
        """Cancel the background job and wait until none of its work runs (its worker holds the capture's
        lock until it stops); True when one was running. A cancelled job leaves everything as it was."""
        bg = self.background
        if bg is None or bg.finished:
            return False
        bg.stop()
        self.outcome = None
        return True

    def end_background(self, job: Job, line: str | None):
        """The background job ended (done, failed or cancelled): what the panel says of it now."""
        if self.background is job:
            self.background, self.outcome = None, line


def train_after_capture(capture: Job, in_ui: bool, enabled: bool) -> bool:
    """Whether a finished Capture starts Train in the background: only a capture done in Blender's UI (a
    script or the command line keeps `capture` as it is) and with the option on."""
    return capture.state == "DONE" and in_ui and enabled


def background_line(slots: JobSlots) -> tuple[str, bool | None] | None:
    """The panel's line on the background Train (text, ok: True plain, False a problem, None greyed), or None."""
    bg = slots.background
    if bg is not None and not bg.finished:
        note = getattr(bg, "in_use_note", "")
        if slots.foreground_running():
            state = "paused" if bg.paused else "pausing"
            return f"Training in the background: {state} at {bg.progress:.0%} while {slots.foreground.title} runs" \
                   + (f" ({note})" if note else ""), None
        if bg.message.startswith("waiting"):  # for the rig, or for the capture's folder
            note = bg.message + (f"; {note}" if note else "")
        return f"Training in the background: {bg.progress:.0%}" + (f" ({note})" if note else ""), True
    if slots.outcome:
        return slots.outcome, False
    return None


def outcome_line(job: Job) -> str | None:
    """What the panel keeps saying after a background job ended: a failure only (done: the models line says
    it; cancelled: nothing changed)."""
    if job.state == "FAILED":
        return f"Training in the background failed: {job.message}"
    return None
