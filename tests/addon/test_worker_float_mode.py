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


def test_a_job_that_needs_no_torch_does_not_load_it_and_a_broken_one_does_not_fail_the_job(monkeypatch):
    import subprocess
    import sys

    root = __import__("pathlib").Path(__file__).resolve().parents[2]
    code = ("import importlib.util, sys\n"
            "spec = importlib.util.spec_from_file_location('lapig', 'lapig_addon/../__init__.py',"
            " submodule_search_locations=['.'])\n"
            "m = importlib.util.module_from_spec(spec); sys.modules['lapig'] = m; spec.loader.exec_module(m)\n"
            "from lapig.lapig_addon.services.jobs import WorkerJob\n"
            "class Plain(WorkerJob):\n"
            "    poll_timeout = 0.01\n"
            "    def work(self, inputs, report, cancel_event):\n"
            "        return 'done'\n"
            "print(Plain().run_to_completion(), 'torch' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root, timeout=120)
    assert out.stdout.split() == ["done", "False"], out.stderr[-2000:]

    float_mode = importlib.import_module("lapig.lapig_addon.services.float_mode")
    denormals = importlib.import_module("lapig.lapig_core.common.denormals")

    def broken():
        raise RuntimeError("no such mode")
    monkeypatch.setattr(denormals, "flush_in_this_thread", broken)
    float_mode.flush_denormals_here()  # says nothing, raises nothing: the work goes on
