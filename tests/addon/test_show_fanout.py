"""The show's frames made once and written per projector at the same time (services/show/show_fanout): every writer gets
its projector's frames in order, and a failure or a cancel on either side stops both sides without a hang."""
import importlib
import threading

import numpy as np
import pytest

fanout = importlib.import_module("lapig.lapig_addon.services.show.show_fanout")


def _frames(count, made, stop_at=None):
    for i in range(count):
        if stop_at is not None and i == stop_at:
            raise RuntimeError("the producer failed")
        made.append(i)
        yield i, [np.full((2, 2), 10 * k + i) for k in range(2)]


def _collect(frames):
    return [int(f[0, 0]) for f in frames]


def test_each_writer_gets_its_projectors_frames_in_order_and_each_frame_is_made_once():
    made, reported = [], []
    out = fanout.write_each(_frames(20, made), [_collect, _collect], reported.append)
    assert out == [list(range(20)), [10 + i for i in range(20)]]
    assert made == list(range(20)) and reported == list(range(20))


def test_a_writer_that_fails_stops_the_show_and_its_error_is_raised():
    made = []

    def broken(frames):
        for n, _ in enumerate(frames):
            if n == 3:
                raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        fanout.write_each(_frames(200, made), [_collect, broken])
    assert len(made) < 200  # the producer stopped soon after
    assert not [t for t in threading.enumerate() if t.name.startswith("lapig show writer")]


def test_a_cancel_or_a_producer_error_stops_every_writer():
    def cancel(index):
        if index == 4:
            raise KeyboardInterrupt("cancelled")

    seen = []
    with pytest.raises(KeyboardInterrupt):
        fanout.write_each(_frames(50, []), [lambda f: seen.append(_collect(f)), _collect], cancel)
    assert seen == []  # the writer was stopped, it did not finish with a short show
    with pytest.raises(RuntimeError, match="the producer failed"):
        fanout.write_each(_frames(50, [], stop_at=7), [_collect, _collect])
    assert not [t for t in threading.enumerate() if t.name.startswith("lapig show writer")]


def test_a_writer_that_stops_reading_early_does_not_block_the_others():
    def first_two(frames):
        out = []
        for f in frames:
            out.append(int(f[0, 0]))
            if len(out) == 2:
                return out

    out = fanout.write_each(_frames(30, []), [first_two, _collect])
    assert out == [[0, 1], [10 + i for i in range(30)]]
