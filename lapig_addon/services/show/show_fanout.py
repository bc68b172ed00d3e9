"""A show's frames made once and written per projector at the same time (Export Show and Bake Show).

The frames of several projectors come together (one joint solve gives every projector's frame), while each
projector's output is its own writer (a video file or a PNG folder) that takes an iterator of that projector's
pixels. Making the whole show once per projector would make every frame K times. Here the job's thread makes each
frame once and hands projector k's pixels to writer k, which runs on a thread of its own and reads them from a small
queue (a few frames: memory stays bounded, and the slower side sets the pace). A failure on either side stops both:
the job's thread raises the first error, after every writer has stopped, so the caller's staged folder can be
discarded whole."""
from __future__ import annotations

import queue
import threading

QUEUE_FRAMES = 3  # frames waiting per projector: the producer runs this far ahead of the slowest writer


class _Stop(Exception):
    """Raised inside a writer's frames when the show's making stopped (an error or a cancel on the job's thread)."""


_END, _ABORT = object(), object()


class _Frames:
    """One projector's frames as its writer reads them, from its queue; knows whether the end was read."""

    def __init__(self):
        self.queue = queue.Queue(maxsize=QUEUE_FRAMES)
        self.ended = False

    def __iter__(self):
        while True:
            item = self.queue.get()
            if item is _END or item is _ABORT:
                self.ended = True
                if item is _ABORT:
                    raise _Stop()
                return
            yield item

    def discard_rest(self):
        """Take the frames still coming until the end, so the producer never blocks on a writer that stopped."""
        while not self.ended:
            item = self.queue.get()
            self.ended = item is _END or item is _ABORT  # identity: a frame is an array


def write_each(frames_iter, writers: list, report=None) -> list:
    """frames_iter yields (index, [pixels per projector]); writers[k](iterator of projector k's pixels) -> result.
    Returns the writers' results in order. report(index) is called after each frame is handed over (it may
    raise, e.g. the job's cancel: then the writers stop and that exception is raised)."""
    streams = [_Frames() for _ in writers]
    queues = [stream.queue for stream in streams]
    results, errors = [None] * len(writers), []

    def run(k):
        try:
            results[k] = writers[k](iter(streams[k]))
        except _Stop:
            pass
        except BaseException as exc:  # noqa: BLE001 (handed to the job's thread, raised there)
            errors.append(exc)
        finally:
            streams[k].discard_rest()

    threads = [threading.Thread(target=run, args=(k,), name=f"lapig show writer {k + 1}", daemon=True)
               for k in range(len(writers))]
    for thread in threads:
        thread.start()
    ended = _END
    try:
        for index, pixels in frames_iter:
            if errors:
                break
            for q, p in zip(queues, pixels):
                q.put(p)
            if report is not None:
                report(index)
    except BaseException:
        ended = _ABORT
        raise
    finally:
        if errors:
            ended = _ABORT
        for q in queues:
            q.put(ended)
        for thread in threads:
            thread.join()
    if errors:
        raise errors[0]
    return results
