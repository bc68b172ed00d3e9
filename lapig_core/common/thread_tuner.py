"""The torch thread count for a long loop of like steps, chosen by timing the steps themselves.

All of a CPU's cores are the fastest way to run Train's small convolutions only while nothing else wants those
cores. Beside a Cycles render in the same Blender, a second Blender's Train, or a headless pipeline, two OpenMP
threads wait for each other at every operation's barrier while one of them is descheduled, and a step can cost
2-4x what one thread's step costs then (BENCHMARKS, "Train beside other work"). Which count is faster depends on
what else runs, and that changes while Train runs, so it is measured, not guessed: every so often a few steps run
with the other count, and the faster count is kept. The trial steps are real training steps; only their speed
differs. On an idle machine the trials lose, and each losing trial doubles the wait before the next one (a Train of
1300 steps on two cores runs 15 of them on one thread, about 1 % of its time). When the
steps' time moves by more than CHANGE from what the last trial saw (other work started or ended), the next trial
comes at once: a Train that ran alone for minutes answers a second Train within a few steps.

torch.set_num_threads under OpenMP applies to the calling thread's parallel regions: the tuner is driven from
the thread that runs the steps, and restore() gives that thread its count back.
"""
from __future__ import annotations

import statistics
import time
from contextlib import contextmanager

FIRST_TRIAL_AFTER = 4  # steps: the first comparison comes early, while most of Train is still ahead
TRIAL_STEPS = 3  # the median of 3 steps at each count is compared
MARGIN = 0.10  # the other count must be this much faster to be taken: step times wander a few percent
PERIOD = 50  # steps between trials after a switch; each trial that loses doubles it
MAX_PERIOD = 1600  # the longest wait at the starting count: other work that starts slows the steps, and that
                   # brings a trial at once (CHANGE), so trials by the clock matter little there
MAX_PERIOD_BELOW_START = 200  # the longest wait on fewer threads: a second Train that ends does not change a
                              # one-thread step's time, so only a trial finds the cores free again
CHANGE = 0.3  # a step time this much above or below the last trial's: the machine's load changed, try again now


class ThreadTuner:
    """Use as `with tuner.step(): <one step>` around each step of a loop, and restore() when the loop ends.

    A trial tries half the count in use, or twice it (never above the starting count), in turn: on two cores
    that is 2 against 1; on sixteen, 16 against 8 first, so that a trial on an idle machine costs little.
    A starting count of 1 leaves nothing to choose: the tuner only times. set_threads, get_threads, clock:
    torch's and time's (tests give fakes)."""

    def __init__(self, set_threads=None, get_threads=None, clock=time.perf_counter,
                 first_trial_after=FIRST_TRIAL_AFTER, trial_steps=TRIAL_STEPS, margin=MARGIN,
                 period=PERIOD, max_period=MAX_PERIOD, change=CHANGE):
        if set_threads is None or get_threads is None:
            import torch

            set_threads = set_threads or torch.set_num_threads
            get_threads = get_threads or torch.get_num_threads
        self._set, self._clock = set_threads, clock
        self.start_count = max(1, int(get_threads()))
        self.current = self.start_count
        self.trial_steps, self.margin = trial_steps, margin
        self.base_period, self.max_period, self.change = period, max_period, change
        self._reference: float | None = None  # the kept count's median step at the last trial
        self._period = first_trial_after
        self._since_trial = 0
        self._recent: list[float] = []  # the last trial_steps step times at self.current
        self._trial: int | None = None  # the count on trial, while one is
        self._trial_times: list[float] = []
        self._next_trial = 0  # which neighbour is tried next, in turn
        self.trials = self.switches = 0
        self.steps_at: dict[int, int] = {}
        self.seconds_at: dict[int, float] = {}
        self.history: list[dict] = []  # one entry per trial: what was compared and what was kept

    @property
    def active(self) -> bool:
        return self.start_count > 1

    def _neighbours(self) -> list[int]:
        return [c for c in dict.fromkeys((self.current // 2, min(self.current * 2, self.start_count)))
                if 1 <= c != self.current]

    @property
    def running_count(self) -> int:
        return self._trial if self._trial is not None else self.current

    @contextmanager
    def step(self):
        count = self.running_count
        t = self._clock()
        yield
        self._record(count, self._clock() - t)

    def _record(self, count: int, seconds: float):
        self.steps_at[count] = self.steps_at.get(count, 0) + 1
        self.seconds_at[count] = self.seconds_at.get(count, 0.0) + seconds
        if not self.active:
            return
        if self._trial is not None:
            self._trial_times.append(seconds)
            if len(self._trial_times) >= self.trial_steps:
                self._decide()
            return
        self._recent = (self._recent + [seconds])[-self.trial_steps:]
        self._since_trial += 1
        if len(self._recent) < self.trial_steps:
            return
        if self._since_trial >= self._period or self._load_changed():
            others = self._neighbours()
            self._trial = others[self._next_trial % len(others)]
            self._next_trial += 1
            self._trial_times = []
            self._set(self._trial)

    def _load_changed(self) -> bool:
        if self._reference is None:
            return False
        ratio = statistics.median(self._recent) / self._reference
        return ratio > 1 + self.change or ratio < 1 / (1 + self.change)

    def _decide(self):
        here, there = statistics.median(self._recent), statistics.median(self._trial_times)
        won = there < here * (1 - self.margin)
        self.trials += 1
        self.history.append({"kept": self._trial if won else self.current, "tried": self._trial,
                             "ms_at_current": round(1000 * here, 1), "ms_tried": round(1000 * there, 1),
                             "current": self.current})
        self._reference = there if won else here
        if won:
            self.current, self._recent = self._trial, list(self._trial_times)
            self.switches += 1
            self._period = self.base_period
        else:
            self._set(self.current)
            longest = self.max_period if self.current == self.start_count else min(self.max_period,
                                                                                    MAX_PERIOD_BELOW_START)
            self._period = min(max(self._period * 2, self.base_period), longest)
        self._trial, self._trial_times, self._since_trial = None, [], 0

    def restore(self):
        """Give the calling thread the count it had when the tuner was made."""
        if self.active:  # an inactive tuner never set a count
            self._set(self.start_count)

    def summary(self) -> dict:
        """What Train reports: the count it started and ended with, how many steps ran at each, their mean ms."""
        return {"start": self.start_count, "end": self.current, "trials": self.trials, "switches": self.switches,
                "steps_at": {str(c): n for c, n in sorted(self.steps_at.items())},
                "ms_per_step_at": {str(c): round(1000 * self.seconds_at[c] / n, 1)
                                   for c, n in sorted(self.steps_at.items()) if n}}
