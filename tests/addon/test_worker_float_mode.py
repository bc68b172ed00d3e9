"""The add-on's worker threads run torch with flush-to-zero (lapig_core/common/denormals: subnormal weights cost
some CPUs several times), set before their first torch operation so torch's own threads have it too; the thread
that steps the job keeps its mode."""
import importlib

import pytest

torch = pytest.importorskip("torch")


def _subnormal_share() -> float:
    """The share of a product of normal floats left subnormal, over all of torch's threads."""
    return float(((torch.full((4_000_000,), 1e-30) * 1e-10) != 0).float().mean())


def test_a_worker_jobs_work_runs_with_flush_to_zero_on_all_of_torchs_threads():
    jobs = importlib.import_module("lapig.lapig_addon.services.jobs")
    if _subnormal_share() == 0.0:
        pytest.skip("this thread (or CPU) flushes subnormals already")

    class Probe(jobs.WorkerJob):
        title = "LAPIG probe"
        poll_timeout = 0.01

        def work(self, inputs, report, cancel_event):
            return _subnormal_share()

    assert Probe().run_to_completion() == 0.0
    assert _subnormal_share() == 1.0  # the stepping thread (Blender's main thread) is left as it was


def test_the_warm_up_thread_sets_it_too(monkeypatch):
    warmup = importlib.import_module("lapig.lapig_addon.services.warmup")
    seen = []
    monkeypatch.setattr(warmup, "warm", lambda backend: seen.append(_subnormal_share()))
    warmup._reset_for_tests()
    assert warmup.start_warmup()
    assert warmup.wait_for_warmup(30)
    warmup._reset_for_tests()
    assert seen == [0.0]
