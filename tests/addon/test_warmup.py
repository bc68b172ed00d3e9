"""The session's warm-up (issue 28, services/warmup): once, on a worker thread, its failure a message; Generate
waits for one under way instead of loading the same models beside it."""
import importlib
import threading
import time

import pytest

ADDON = "lapig.lapig_addon"


@pytest.fixture
def warmup(monkeypatch):
    module = importlib.import_module(ADDON + ".services.warmup")
    module._reset_for_tests()
    yield module
    module.wait_for_warmup(10)
    module._reset_for_tests()


def test_the_warm_up_runs_once_off_the_calling_thread(warmup, monkeypatch):
    threads, release = [], threading.Event()

    def fake_warm(backend=None):
        threads.append((threading.current_thread().name, backend))
        release.wait(5)
    monkeypatch.setattr(warmup, "warm", fake_warm)
    assert warmup.start_warmup("styletransfer") is True
    assert warmup.start_warmup("styletransfer") is False  # once per session
    assert warmup.warmup_state()["running"] is True
    assert warmup.wait_for_warmup(0.05) is False  # still loading
    release.set()
    assert warmup.wait_for_warmup(5) is True
    state = warmup.warmup_state()
    assert state["running"] is False and state["error"] is None and state["seconds"] >= 0
    assert threads == [("LAPIG: warm-up", "styletransfer")]


def test_a_failed_warm_up_says_why_and_raises_nothing(warmup, monkeypatch):
    def broken(backend=None):
        raise OSError("the style weights are missing")
    monkeypatch.setattr(warmup, "warm", broken)
    warmup.start_warmup()
    assert warmup.wait_for_warmup(5)
    assert warmup.warmup_state()["error"] == "OSError: the style weights are missing"


def test_waiting_without_a_warm_up_returns_at_once(warmup):
    t = time.perf_counter()
    assert warmup.wait_for_warmup() is True
    assert time.perf_counter() - t < 0.5
