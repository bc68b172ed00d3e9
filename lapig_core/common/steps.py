"""Running a generator of progress steps to its end outside a job (a command, a benchmark, a test).

The capture sequence, the projections and the refinement are generators: a job yields their steps to
the UI and takes their return value with ``yield from``; everything else runs them here.
"""
from __future__ import annotations

from typing import Callable, Generator


def run_to_end(steps: Generator, on_step: Callable | None = None):
    """Step ``steps`` to its end; its return value. on_step(each step it yields): True closes the generator
    there, as a job's cancel does, and None is returned."""
    while True:
        try:
            step = next(steps)
        except StopIteration as done:
            return done.value
        if on_step is not None and on_step(step):
            steps.close()
            return None


def mapped_steps(steps: Generator, as_step: Callable):
    """A generator of as_step(each step of ``steps``) whose value is theirs (``yield from`` it in a job); closed,
    it closes ``steps`` (and the device they hold) at once."""
    try:
        while True:
            try:
                step = next(steps)
            except StopIteration as done:
                return done.value
            yield as_step(step)
    finally:
        steps.close()
