"""Train in the background (issue 28): a job pauses at its pause points (a worker's report, the main thread's
pause_point) having let go of its lock, resumes, cancels cleanly while paused; the session's slots keep one
background job at most, pause it for the artist's job and resume it after; a Capture done in the UI starts
it when the option is on. bpy blocked; fake jobs, then the real Train on the fake rig of job_fakes."""
import importlib
import json
import os
import threading
import time

import pytest

from lapig.lapig_core.capture.dataset import resolve_setup

ADDON = "lapig.lapig_addon"
# the add-on package's lock, whose FolderBusy the job engine catches
locking = importlib.import_module("lapig.lapig_core.common.locking")
FolderBusy, FolderLock = locking.FolderBusy, locking.FolderLock


def _module(name):
    return importlib.import_module(f"{ADDON}.services.{name}")


def _until(condition, step=lambda: None, timeout=20.0):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail("timed out")
        step()
        time.sleep(0.002)


def _counting_job(folder, iterations=40, reports_every=1, pause_at=None):
    """A worker job that counts, reports after each count (its pause points), holds the folder's lock and
    writes its output file only at the end. As the Trainer, it checks for a cancel at the top of its loop only.
    pause_at: the count whose report it is paused at."""
    jobs = _module("jobs")

    class Counting(jobs.WorkerJob):
        title = "LAPIG counting"
        poll_timeout = 0.0  # as under Blender's timer

        def __init__(self):
            super().__init__()
            self.count = 0
            self.resumes = 0

        def hold(self, inputs):
            return FolderLock(folder, self.title).acquire()

        def work(self, inputs, report, cancel_event):
            for i in range(iterations):
                if cancel_event.is_set():
                    return None
                self.count += 1
                time.sleep(0.002)
                if self.count == pause_at:
                    self.pause()
                if i % reports_every == 0:
                    report(i / iterations, f"counted {self.count}")
            (folder / "output.txt").write_text(str(self.count))
            return self.count

        def resumed(self, inputs):
            self.resumes += 1

    return Counting()


def _lock_is_free(folder) -> bool:
    try:
        FolderLock(folder, "LAPIG check").acquire().release()
    except FolderBusy:
        return False
    return True


def _worker_gone(job):
    return job._thread is None or not job._thread.is_alive()


def test_a_paused_worker_stops_lets_go_of_its_lock_and_goes_on_after_resume(tmp_path):
    job = _counting_job(tmp_path)
    _until(lambda: job.count >= 3, job.step)
    assert not _lock_is_free(tmp_path)
    job.pause()
    _until(lambda: job.paused, job.step)
    stopped_at = job.count
    time.sleep(0.2)
    assert job.step() and job.count == stopped_at  # paused: no progress, whatever is stepped
    assert _lock_is_free(tmp_path)  # the artist's job can take the capture's folder
    job.resume()
    _until(lambda: job.finished, job.step)
    assert job.state == "DONE" and job.result == 40 and job.resumes == 1
    assert (tmp_path / "output.txt").read_text() == "40"
    _until(lambda: _worker_gone(job) and _lock_is_free(tmp_path))


def test_a_cancel_while_paused_ends_cleanly_and_leaves_nothing_behind(tmp_path):
    job = _counting_job(tmp_path)
    _until(lambda: job.count >= 2, job.step)
    job.pause()
    _until(lambda: job.paused, job.step)
    job.stop()  # cancels and waits for the worker: it stops without waiting for a resume
    assert job.state == "CANCELLED" and not job.paused and job.count < 40
    assert _worker_gone(job) and _lock_is_free(tmp_path)
    assert sorted(os.listdir(tmp_path)) == []  # no output, and no lock file left


def test_a_cancel_while_paused_at_the_last_report_stops_the_work_before_it_saves(tmp_path):
    """Train paused at PCNet's last report, then cancelled: its loop would end without checking for a cancel
    again, and save."""
    job = _counting_job(tmp_path, iterations=5, pause_at=5)
    _until(lambda: job.paused, job.step)
    job.stop()
    assert job.state == "CANCELLED" and _worker_gone(job)
    assert sorted(os.listdir(tmp_path)) == []  # nothing saved, and no lock file left


def test_on_resume_a_folder_still_taken_is_waited_for_then_refused_with_its_holder(tmp_path):
    job = _counting_job(tmp_path)
    job.RETAKE_S = 0.3
    _until(lambda: job.count >= 2, job.step)
    job.pause()
    _until(lambda: job.paused, job.step)
    with FolderLock(tmp_path, "LAPIG capture"):  # another process captures meanwhile
        resumed_at = time.monotonic()
        job.resume()
        _until(lambda: job.finished, job.step)
    assert time.monotonic() - resumed_at >= job.RETAKE_S  # waited for, not refused at once
    assert job.state == "FAILED" and "in use by LAPIG capture" in job.message
    assert not (tmp_path / "output.txt").exists()
    _until(lambda: _worker_gone(job) and _lock_is_free(tmp_path))


def test_on_resume_a_folder_taken_for_a_moment_is_waited_for_and_the_work_goes_on(tmp_path):
    job = _counting_job(tmp_path)
    _until(lambda: job.count >= 2, job.step)
    job.pause()
    _until(lambda: job.paused, job.step)
    capture = FolderLock(tmp_path, "LAPIG capture").acquire()  # the foreground job's, still ending
    job.resume()
    for _ in range(20):
        job.step()
        time.sleep(0.005)
    assert not job.finished
    capture.release()
    _until(lambda: job.finished, job.step)
    assert job.state == "DONE" and job.result == 40 and job.resumes == 1


def test_a_main_thread_pause_point_holds_the_steps_until_resume():
    jobs = _module("jobs")
    done = []

    class Renders(jobs.Job):
        def steps(self):
            for i in range(4):
                yield from self.pause_point(i / 4)
                done.append(i)
                yield (i + 1) / 4, f"render {i}"

    job = Renders()
    job.step()
    job.pause()
    for _ in range(5):
        job.step()
    assert job.paused and done == [0] and job.message == "paused"
    job.resume()
    assert job.run() == "DONE" and done == [0, 1, 2, 3]
    job = Renders()
    job.pause()
    job.step()
    job.cancel()  # cancelled at its pause point
    assert job.state == "CANCELLED" and done == [0, 1, 2, 3]


def test_the_slots_pause_the_background_job_for_the_foreground_and_keep_one_at_most(tmp_path):
    background_jobs = _module("background_jobs")
    slots = background_jobs.JobSlots()
    train = _counting_job(tmp_path / "a", iterations=60)
    assert slots.start_background(train)
    assert not slots.start_background(_counting_job(tmp_path / "b"))  # never two
    _until(lambda: train.count >= 3, slots.step_background)
    assert background_jobs.background_line(slots)[0].startswith("Training in the background: ")

    generate = _counting_job(tmp_path / "a", iterations=5)  # the same folder: it needs the lock
    generate.title = "LAPIG generate"
    assert slots.start_foreground(generate) is None
    assert slots.start_foreground(_counting_job(tmp_path / "c")) == background_jobs.BUSY
    _until(slots.foreground_may_step)  # steps the background job to its pause point
    text, ok = background_jobs.background_line(slots)
    assert "paused" in text and "LAPIG generate" in text and ok is None
    paused_at = train.count
    slots.step_background()  # its own timer keeps it paused while the artist's job runs
    _until(lambda: generate.finished, lambda: slots.foreground_may_step() and generate.step())
    assert generate.state == "DONE" and train.count == paused_at
    slots.end_foreground(generate)
    _until(lambda: train.finished, slots.step_background)
    assert train.state == "DONE" and train.result == 60
    slots.end_background(train, background_jobs.outcome_line(train))
    assert background_jobs.background_line(slots) is None
    assert slots.start_background(_counting_job(tmp_path / "d"))  # the slot is free again


def test_a_background_job_started_under_a_foreground_job_waits_for_it(tmp_path):
    background_jobs = _module("background_jobs")
    slots = background_jobs.JobSlots()
    capture = _counting_job(tmp_path / "a", iterations=5)
    slots.start_foreground(capture)
    train = _counting_job(tmp_path / "b")
    slots.start_background(train)
    for _ in range(20):
        slots.step_background()
    assert train.count <= 1 and not train.finished
    _until(lambda: capture.finished, capture.step)
    slots.end_foreground(capture)
    _until(lambda: train.finished, slots.step_background)
    assert train.state == "DONE"


def test_cancelling_the_background_job_waits_for_its_worker_and_says_nothing_after(tmp_path):
    background_jobs = _module("background_jobs")
    slots = background_jobs.JobSlots()
    train = _counting_job(tmp_path, iterations=500)
    slots.start_background(train)
    _until(lambda: train.count >= 2, slots.step_background)
    assert slots.cancel_background()
    assert train.state == "CANCELLED" and _worker_gone(train) and _lock_is_free(tmp_path)
    assert not slots.cancel_background()  # none runs any more
    slots.end_background(train, background_jobs.outcome_line(train))
    assert background_jobs.background_line(slots) is None  # cancelled: nothing changed, nothing to say


def test_a_failed_background_job_is_said_in_the_panel(tmp_path):
    background_jobs = _module("background_jobs")
    slots = background_jobs.JobSlots()
    train = _counting_job(tmp_path)
    train.work = lambda inputs, report, cancel_event: 1 / 0
    slots.start_background(train)
    _until(lambda: train.finished, slots.step_background)
    slots.end_background(train, background_jobs.outcome_line(train))
    text, ok = background_jobs.background_line(slots)
    assert text.startswith("Training in the background failed: ") and "division by zero" in text and ok is False


def test_a_capture_done_in_blenders_ui_starts_train_when_the_option_is_on(seams):
    background_jobs = _module("background_jobs")
    capture = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings(train_count=2, test_count=0))
    capture.run()
    assert capture.state == "DONE"
    assert background_jobs.train_after_capture(capture, in_ui=True, enabled=True)
    assert not background_jobs.train_after_capture(capture, in_ui=True, enabled=False)  # the option off
    assert not background_jobs.train_after_capture(capture, in_ui=False, enabled=True)  # a script, the CLI
    cancelled = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings())
    cancelled.step()
    cancelled.stop()
    assert not background_jobs.train_after_capture(cancelled, in_ui=True, enabled=True)


def _running_job():
    """A foreground job as the slots see it: running until it is told otherwise."""
    job = _module("jobs").Job()
    job.state = "RUNNING"
    return job


def _root(captured):
    """The data set root, whose lock the capture, Train and Generate take."""
    return resolve_setup(captured["setup_dir"]).root


def _models_files(captured):
    return sorted(os.listdir(os.path.join(captured["setup_dir"], "models")))


@pytest.mark.torch
@pytest.mark.parametrize("main_thread", [False, True], ids=["real-rig-thread", "cycles-main-thread"])
def test_generate_while_train_runs_in_the_background_uses_the_first_look_and_after_it_trains_choice(seams,
                                                                                                      main_thread):
    train_job, generate_job = _module("train.train_job"), _module("generate.generate_job")
    background_jobs = _module("background_jobs")
    seams.devices.main_thread = main_thread
    captured = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    store, slots = seams.store, background_jobs.JobSlots()
    train = train_job.TrainModelsJob(seams, 2)
    train.poll_timeout = 0
    train.check()
    assert slots.start_background(train)

    generate = generate_job.GenerateJob(seams, store.generate_request(mix="charcoal_wash:1", psa=False), 2)
    assert slots.start_foreground(generate) is None  # the artist generates at once
    _until(slots.foreground_may_step, timeout=120)
    assert train.paused and train.in_use_note == "first look in use until it finishes"
    assert generate.run() == "DONE", generate.message
    summary = json.load(open(os.path.join(generate.result["folder"], "result.json")))
    assert summary["models"]["first_look"] is True
    slots.end_foreground(generate)

    # paused again during the rendered choice: the device closes and the lock goes between renders
    # a camera on its own thread waits at its first grab until the pause is asked (Cycles: stepped here only)
    grabs = seams.devices.grab_gate = threading.Event()
    if main_thread:
        grabs.set()
    opened = seams.devices.opened
    _until(lambda: seams.devices.opened > opened, slots.step_background, timeout=300)
    assert train.in_use_note.startswith("networks saved")
    slots.start_foreground(_running_job())
    grabs.set()
    _until(slots.foreground_may_step, timeout=60)
    assert train.paused and "measuring" not in train.message  # between two renders
    assert seams.devices.opened == seams.devices.closed
    assert _lock_is_free(_root(captured))
    slots.end_foreground(slots.foreground)
    _until(lambda: train.finished, slots.step_background, timeout=300)
    assert train.state == "DONE", train.message
    assert seams.devices.opened == seams.devices.closed
    from lapig.lapig_core.photometric.choice import RENDERED_JUDGE

    choice = json.load(open(os.path.join(captured["setup_dir"], "models", "compensator_choice.json")))
    assert choice["judge"] == RENDERED_JUDGE  # every held-back image rendered, across the pause
    assert store.models[0] == store.capture_fingerprint and "first look" in store.models[1]
    later = generate_job.GenerateJob(seams, store.generate_request(mix="charcoal_wash:1", psa=False), 2)
    models = json.load(open(os.path.join(later.run_to_completion()["folder"], "result.json")))["models"]
    assert models["first_look"] is False and models["compensator"] == choice["chosen"]


@pytest.mark.torch
def test_a_background_train_cancelled_while_paused_leaves_the_first_look_as_it_was(seams):
    train_job, background_jobs = _module("train.train_job"), _module("background_jobs")
    captured = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    before, models_before = _models_files(captured), seams.store.models
    slots = background_jobs.JobSlots()
    train = train_job.TrainModelsJob(seams, 2)
    train.poll_timeout = 0
    train.check()
    slots.start_background(train)
    slots.start_foreground(_running_job())  # any foreground job pauses it
    _until(slots.foreground_may_step, timeout=120)
    assert slots.cancel_background()  # a new Capture, Train pressed, the panel's Cancel
    assert train.state == "CANCELLED" and _worker_gone(train)
    assert _models_files(captured) == before and seams.store.models == models_before
    assert _lock_is_free(_root(captured))


@pytest.mark.torch
def test_a_train_cancelled_while_paused_at_pcnets_last_report_saves_nothing(seams):
    train_job = _module("train.train_job")
    captured = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    before, models_before = _models_files(captured), seams.store.models

    class PausedAtPCNet(train_job.TrainModelsJob):
        def work(self, folder, report, cancel_event):
            def pause_at_pcnet(progress, message):  # 2 iterations: PCNet reports once, at its last
                if message.startswith("PCNet"):
                    self.pause()
                report(progress, message)

            return super().work(folder, pause_at_pcnet, cancel_event)

    train = PausedAtPCNet(seams, 2)
    train.poll_timeout = 0
    _until(lambda: train.paused, train.step, timeout=120)
    train.stop()
    assert train.state == "CANCELLED" and _worker_gone(train)
    assert _models_files(captured) == before and seams.store.models == models_before
    assert _lock_is_free(_root(captured))


@pytest.mark.torch
def test_a_cancelled_train_lets_go_of_the_capture_only_once_its_camera_is_closed(seams):
    """Esc while the rendered choice's camera grabs on its own thread: a background job that resumed on the
    lock meanwhile would open the same camera."""
    train_job = _module("train.train_job")
    captured = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    grabs = seams.devices.grab_gate = threading.Event()  # the camera's grab blocks until set
    train = train_job.TrainModelsJob(seams, 2)
    train.poll_timeout = 0
    _until(lambda: seams.devices.opened > seams.devices.closed, train.step, timeout=300)
    train.cancel()  # the UI stops waiting; the camera is still grabbing
    assert train.state == "CANCELLED" and not _lock_is_free(_root(captured))
    grabs.set()
    _until(lambda: _lock_is_free(_root(captured)))
    assert seams.devices.opened == seams.devices.closed  # closed before the lock went
    train.stop()


@pytest.mark.torch
def test_a_background_train_waits_for_the_artists_live_window_before_it_opens_the_rig(seams):
    train_job, background_jobs = _module("train.train_job"), _module("background_jobs")
    seams.devices.main_thread = True
    _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    slots, in_use = background_jobs.JobSlots(), ["close the projector window"]
    train = train_job.TrainModelsJob(seams, 2)
    train.poll_timeout, train.rig_in_use = 0, lambda: in_use[0]
    train.check()
    slots.start_background(train)
    opened = seams.devices.opened
    _until(lambda: train.message.startswith("waiting for the rig"), slots.step_background, timeout=300)
    for _ in range(5):
        slots.step_background()
    assert seams.devices.opened == opened and not train.finished  # the rig was not opened
    text, ok = background_jobs.background_line(slots)
    assert "waiting for the rig: close the projector window" in text and ok
    in_use[0] = ""
    _until(lambda: train.finished, slots.step_background, timeout=300)
    assert train.state == "DONE" and seams.devices.opened > opened


class _Clock:
    """background_jobs' time, moved on by the test."""

    def __init__(self):
        self.now = 0.0
        self.sleep = time.sleep

    def monotonic(self):
        return self.now


def _long_step_then_a_report(folder, go_on):
    """A background job holding the folder's lock through a long step without a pause point (a fit, a load)."""
    train = _counting_job(folder)

    def work(inputs, report, cancel_event):
        go_on.wait(20)
        report(0.5, "fitted")
        return "fitted"

    train.work = work
    return train


def _slots_with_a_train_in_a_long_step(tmp_path, monkeypatch):
    """(background_jobs, the slots' clock, the slots, the Event that ends the Train's long step, the Train)."""
    background_jobs = _module("background_jobs")
    clock = _Clock()
    monkeypatch.setattr(background_jobs, "time", clock)
    slots, go_on = background_jobs.JobSlots(), threading.Event()
    train = _long_step_then_a_report(tmp_path, go_on)
    slots.start_background(train)
    slots.step_background()
    return background_jobs, clock, slots, go_on, train


def test_a_foreground_job_waits_for_a_background_train_that_takes_long_to_pause(tmp_path, monkeypatch):
    background_jobs, clock, slots, go_on, train = _slots_with_a_train_in_a_long_step(tmp_path, monkeypatch)
    generate = _counting_job(tmp_path, iterations=5)  # the same folder: it needs the lock the Train holds
    slots.start_foreground(generate)
    clock.now += 120  # four times the old 30 s cap, well short of a stuck job: the artist's job still waits
    assert not slots.foreground_may_step() and not generate.finished
    assert generate.message == background_jobs.WAITING_FOR_PAUSE
    assert "pausing" in background_jobs.background_line(slots)[0]
    go_on.set()
    _until(slots.foreground_may_step)
    _until(lambda: generate.finished, generate.step)
    assert generate.state == "DONE", generate.message
    slots.end_foreground(generate)
    _until(lambda: train.finished, slots.step_background)
    assert train.state == "DONE" and train.result == "fitted"


def test_a_background_job_that_never_pauses_fails_the_foreground_job_saying_so(tmp_path, monkeypatch):
    background_jobs, clock, slots, go_on, train = _slots_with_a_train_in_a_long_step(tmp_path, monkeypatch)
    generate = _running_job()
    slots.start_foreground(generate)
    clock.now += slots.STUCK_S + 1
    assert not slots.foreground_may_step()
    assert generate.state == "FAILED" and generate.message.startswith("the training in the background did not pause")
    assert "Cancel" in generate.message and not train.finished  # the artist decides: cancel it, or wait
    go_on.set()
    slots.cancel_background()


def test_a_synchronous_run_in_the_ui_waits_for_the_pause_then_resumes_the_background_job(tmp_path):
    """A script calling an operator while Train runs in the background (JobRunnerMixin.execute)."""
    background_jobs = _module("background_jobs")
    slots = background_jobs.JobSlots()
    train = _counting_job(tmp_path, iterations=60)
    slots.start_background(train)
    _until(lambda: train.count >= 2, slots.step_background)
    assert slots.pause_background_until_paused(timeout_s=20)
    assert train.paused and _lock_is_free(tmp_path)
    slots.resume_background()
    _until(lambda: train.finished, slots.step_background)
    assert train.state == "DONE" and train.result == 60


@pytest.mark.torch
def test_in_the_background_a_main_thread_device_is_opened_and_closed_within_each_render_step(seams):
    train_job = _module("train.train_job")
    from lapig.lapig_core.photometric.choice import RENDERED_JUDGE

    seams.devices.main_thread = True  # Cycles: its studio is a scene of its own in the artist's file
    captured = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    train = train_job.TrainModelsJob(seams, 2)
    train.poll_timeout, train.device_per_render = 0, True
    train.check()
    opened = seams.devices.opened
    while train.step():
        assert seams.devices.opened == seams.devices.closed  # never open between two steps
    assert train.state == "DONE", train.message
    choice = json.load(open(os.path.join(captured["setup_dir"], "models", "compensator_choice.json")))
    assert choice["judge"] == RENDERED_JUDGE
    assert seams.devices.opened - opened == 2 * choice["validation_pairs"]  # one opening per render


@pytest.mark.torch
def test_trains_choice_computes_its_compensations_off_a_main_thread_rig(seams, monkeypatch):
    """With Cycles (a main-thread rig) the rendered choice's steps run on Blender's thread: CompenNeSt's pass
    over the held-back images (the compensations it renders) must run on the training's worker thread."""
    train_job = _module("train.train_job")
    seams.devices.main_thread = True
    _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    choice = importlib.import_module("lapig.lapig_core.photometric.choice")
    verification, computed_on = choice.verification, []

    def verification_and_where(*args, **kwargs):
        computed_on.append(threading.current_thread())
        return verification(*args, **kwargs)

    monkeypatch.setattr(train_job.compensator_choice, "verification", verification_and_where)
    out = train_job.TrainModelsJob(seams, 2).run_to_completion()
    assert "held-back images" in out["choice"] and "verification" not in out
    assert computed_on and threading.main_thread() not in computed_on, "the choice's compensations ran on the main thread"
