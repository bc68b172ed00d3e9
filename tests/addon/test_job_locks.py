"""A worker job holds its folder's lock from before its work starts until the work has stopped."""
import importlib
import threading

import pytest

from lapig.lapig_core.common.locking import FolderBusy, FolderLock


@pytest.fixture
def jobs():
    return importlib.import_module("lapig.lapig_addon.services.jobs")


def _locking_job(jobs, folder, started, go_on):
    class Training(jobs.WorkerJob):
        title = "LAPIG training"
        poll_timeout = 0.01

        def hold(self, inputs):
            return FolderLock(folder, self.title).acquire()

        def work(self, inputs, report, cancel_event):
            started.set()
            go_on.wait(10)
            return "trained"

    return Training()


def test_the_lock_is_held_while_the_work_runs_even_after_a_cancel(jobs, tmp_path):
    started, go_on = threading.Event(), threading.Event()
    job = _locking_job(jobs, tmp_path, started, go_on)
    job.step()
    assert started.wait(10)
    with pytest.raises(FolderBusy, match="in use by LAPIG training"):
        FolderLock(tmp_path, "LAPIG capture").acquire()
    job.cancel()  # the UI stops waiting; the worker is still writing
    with pytest.raises(FolderBusy):
        FolderLock(tmp_path, "LAPIG capture").acquire()
    go_on.set()
    for _ in range(500):  # until the worker has stopped
        try:
            FolderLock(tmp_path, "LAPIG capture").acquire().release()
            break
        except FolderBusy:
            threading.Event().wait(0.01)
    else:
        pytest.fail("the worker kept the lock after its work had stopped")


def test_a_job_whose_folder_is_busy_fails_with_the_holders_name_before_any_work(jobs, tmp_path):
    started, go_on = threading.Event(), threading.Event()
    with FolderLock(tmp_path, "LAPIG capture"):
        job = _locking_job(jobs, tmp_path, started, go_on)
        assert job.run() == "FAILED"
    assert "is in use by LAPIG capture (pid" in job.message and not started.is_set()
    go_on.set()
    assert _locking_job(jobs, tmp_path, started, go_on).run_to_completion() == "trained"
