"""The job engine: long work as a generator of progress steps, driven one step at a time.

The same object runs to completion in headless runs and tests, and is stepped by a modal
operator's timer inside Blender's UI (bpy.app.timers never fire in the bpy module). Cancelling
closes the generator, so its `with`/`finally` blocks undo whatever it had changed.
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Iterator

from ...lapig_core.common.locking import FolderBusy
from .errors import one_line
from .float_mode import flush_denormals_here



THREAD_PREFIX = "LAPIG: "  # every worker thread of a job: tests wait for them between tests

class JobCancelled(Exception):
    pass


class Job:
    title = "LAPIG job"

    def __init__(self):
        self.progress = 0.0
        self.message = "waiting"
        self.state = "PENDING"  # PENDING, RUNNING, DONE, CANCELLED, FAILED
        self.error: BaseException | None = None
        self.result = None
        self._gen: Iterator | None = None
        self.started_at = None
        self.finished_at = None
        self._device_steps = []  # DeviceSteps this job drives: stop() waits for their threads
        self._go = threading.Event()  # cleared while a pause is asked for (a job in the background)
        self._go.set()
        self._at_pause_point = False  # the work has stopped at a pause point, its locks and devices let go

    def steps(self) -> Iterator[tuple[float, str]]:
        """Yield (progress 0..1, message) between chunks of work; set self.result at the end."""
        raise NotImplementedError

    @property
    def finished(self) -> bool:
        return self.state in {"DONE", "CANCELLED", "FAILED"}

    # Pausing: a job in the background gives the cores (and its locks and devices) to the artist's job.
    # pause() asks; the work stops at its next pause point (a worker's report(), the main thread's
    # pause_point()); `paused` says it has; resume() lets it go on. A paused job still cancels.
    def pause(self):
        self._go.clear()

    def resume(self):
        self._go.set()

    @property
    def pause_requested(self) -> bool:
        return not self._go.is_set()

    @property
    def paused(self) -> bool:
        return self.pause_requested and self._at_pause_point and not self.finished

    def pause_point(self, progress: float):
        """Main-thread steps: `yield from` it where the job holds no lock nor device; while paused it yields
        once and step() does not advance it until resume()."""
        while self.pause_requested:
            self._at_pause_point = True
            yield progress, "paused"
        self._at_pause_point = False

    def step(self) -> bool:
        """Advance by one chunk; returns True while there is more to do (a paused job does not advance)."""
        if self.finished:
            return False
        if self.paused:
            return True
        if self._gen is None:
            self.state, self.started_at = "RUNNING", time.perf_counter()
            self._gen = self.steps()
        try:
            self.progress, self.message = next(self._gen)
        except StopIteration:
            self._finish("DONE", 1.0, "done")
        except JobCancelled:
            self._finish("CANCELLED", self.progress, "cancelled")
        except Exception as exc:  # reported to the user by the operator or the CLI
            self.error = exc
            self._finish("FAILED", self.progress, one_line(exc))
        return not self.finished

    def cancel(self):
        if self.finished:
            return
        if self._gen is not None:
            self._gen.close()  # runs the generator's cleanup at its current yield
        self._finish("CANCELLED", self.progress, "cancelled")

    def fail(self, error: Exception):
        """End the job as failed with `error`, from outside its steps (what kept it from going on); its
        cleanup runs as on a cancel."""
        if self.finished:
            return
        if self._gen is not None:
            self._gen.close()
        self.error = error
        self._finish("FAILED", self.progress, one_line(error))

    def stop(self):
        """Cancel and return once no work of this job runs any more."""
        self.cancel()
        self._join_devices()

    poll_timeout = 0.05  # > 0: synchronous runs (headless, tests) wait for a worker instead of spinning

    def drive(self, make_steps, main_thread: bool, holding=None) -> "DeviceSteps":
        """Steps that drive a capture device on the thread it needs (DeviceSteps); `yield from` them.
        holding: a lock the device works under (release()), let go once the device is closed."""
        steps = DeviceSteps(make_steps, main_thread, self.poll_timeout, self.title, holding)
        self._device_steps.append(steps)
        return steps

    def _join_devices(self):
        for steps in self._device_steps:
            steps.join()

    def _finish(self, state, progress, message):
        self.state, self.progress, self.message = state, progress, message
        self.finished_at = time.perf_counter()

    def run(self, on_progress: Callable[[float, str], None] | None = None,
            should_cancel: Callable[[], bool] | None = None) -> str:
        """Step until finished; returns the final state (failures stay in self.error)."""
        try:
            while self.step():
                if on_progress:
                    on_progress(self.progress, self.message)
                if should_cancel and should_cancel():
                    self.cancel()
        except KeyboardInterrupt:  # Ctrl-C in a headless run: undo as Esc does, then let the caller exit
            if on_progress:
                on_progress(self.progress, "interrupted: stopping")
            self.stop()
            raise
        if on_progress:
            on_progress(self.progress, self.message)
        return self.state

    def run_to_completion(self, on_progress: Callable[[float, str], None] | None = None,
                          should_cancel: Callable[[], bool] | None = None):
        """Like run(), but a failure raises its exception; returns the job's result."""
        if self.run(on_progress, should_cancel) == "FAILED":
            raise self.error
        return self.result

    @property
    def elapsed(self) -> float:
        if self.started_at is None:
            return 0.0
        return (self.finished_at or time.perf_counter()) - self.started_at


class WorkerJob(Job):
    """A job whose heavy part (torch, numpy; never bpy) runs on a worker thread.

    prepare() reads what the work needs from bpy on the main thread, hold() then takes the locks of
    the folders it writes (released when the work stops), work() runs on the thread and reports
    progress through a queue, finish() writes the result back into bpy on the main thread.
    Each step() only drains the queue, so Blender's main thread never waits for the work;
    poll_timeout > 0 makes synchronous runs (headless, tests) wait instead of spinning.
    A pause stops the work in report(): the worker lets go of its locks there, waits, takes them again
    on resume (RETAKE_S at most, while the job that had them ends) and asks resumed() whether its
    inputs still hold.
    """

    RETAKE_S = 30.0

    _NOT_PREPARED = object()
    _inputs = _NOT_PREPARED
    _thread = None

    def prepare(self):
        return None

    def check(self):
        """Prepare now, so an operator reports a problem before any work starts; steps() reuses it."""
        self._inputs = self.prepare()
        return self._inputs

    def hold(self, inputs):
        """Take the locks the work needs (an object with release(), or None); refuse by raising."""
        return None

    def work(self, inputs, report, cancel_event):
        raise NotImplementedError

    def finish(self, output):
        return output

    def resumed(self, inputs):
        """After a pause, on the worker thread with the locks taken again: raise if the inputs changed meanwhile."""

    def stop(self):
        """Cancel, and wait for the worker to see it: torch work left running when Python exits aborts it."""
        self.cancel()  # sets cancel_event while the worker runs
        if self._thread is not None:
            self._thread.join()
        self._join_devices()

    def steps(self):
        import queue
        import threading

        inputs = self.prepare() if self._inputs is self._NOT_PREPARED else self._inputs
        messages = queue.Queue()
        self.cancel_event = threading.Event()
        box = {}
        locks = {"held": self.hold(inputs)}

        def release():
            held, locks["held"] = locks["held"], None
            if held is not None:
                held.release()

        def report(progress, message):
            messages.put((float(progress), str(message)))
            if self.pause_requested:
                self._paused_in_worker(inputs, locks, release)
            if self.cancel_event.is_set():  # the work stops here: a loop that would end now must not save
                raise JobCancelled()

        def target():
            try:
                flush_denormals_here()
                box["output"] = self.work(inputs, report, self.cancel_event)
            except BaseException as exc:  # handed to the main thread, raised there
                box["error"] = exc
            finally:  # when the work has stopped, not when a cancel stops waiting for it
                release()

        thread = self._thread = threading.Thread(target=target, name=f"{THREAD_PREFIX}{self.title}", daemon=True)
        try:
            thread.start()
        except BaseException:
            release()
            raise
        progress, message = 0.0, "starting"
        try:
            while thread.is_alive() or not messages.empty():
                try:
                    progress, message = messages.get(timeout=self.poll_timeout) if self.poll_timeout \
                        else messages.get_nowait()
                    while not messages.empty():  # only the latest matters
                        progress, message = messages.get_nowait()
                except queue.Empty:
                    pass
                yield min(progress, 0.99), message
        finally:
            if thread.is_alive():  # cancelled: tell the worker, do not wait for it on the UI thread
                self.cancel_event.set()
        if "error" in box:
            raise box["error"]
        if self.cancel_event.is_set():
            raise JobCancelled()
        self.result = self.finish(box.get("output"))
        yield 1.0, "done"

    def _paused_in_worker(self, inputs, locks, release):
        """On the worker thread: let go of the locks, wait for resume() or a cancel, take them again. A cancel
        raises JobCancelled: the work ends here, holding nothing and saving nothing."""
        release()
        self._at_pause_point = True
        try:
            while not self._go.wait(0.05):
                if self.cancel_event.is_set():
                    raise JobCancelled()
        finally:
            self._at_pause_point = False
        retake = self.retake(inputs)
        while True:
            if self.cancel_event.is_set():
                retake.close()
                raise JobCancelled()
            try:
                next(retake)
            except StopIteration as done:
                locks["held"] = done.value
                return
            time.sleep(0.1)

    def retake(self, inputs):
        """Take the inputs' locks again after a pause, once the job that paused this one has let go of them
        (RETAKE_S at most), then check with resumed() that the inputs still hold. A generator: it yields each
        time the lock is still taken (the caller waits, or gives up by closing it) and returns the held lock."""
        deadline = time.monotonic() + self.RETAKE_S
        while True:
            try:
                held = self.hold(inputs)
                break
            except FolderBusy:
                yield
                if time.monotonic() > deadline:
                    raise
        try:
            self.resumed(inputs)
        except BaseException:
            if held is not None:
                held.release()
            raise
        return held


class DeviceSteps:
    """Steps that drive a capture device, on the thread the device needs.

    `make_steps()` returns a generator of (progress, message) whose return value is the result.
    With main_thread (Cycles renders through bpy) it runs where the job is stepped; without, it runs
    on a worker thread whose steps are relayed here, so a real camera's blocking grab() never freezes
    Blender. Closing this generator (a cancel) closes the inner one on the thread that runs it, and
    its `with` blocks close the device; join() waits for that. `holding` (a lock, or None) is let go
    only then: a cancel does not wait for a blocked grab, and the next job must not open the device
    meanwhile."""

    def __init__(self, make_steps, main_thread: bool, poll_timeout: float = 0.05, title: str = "LAPIG device",
                 holding=None):
        self.make_steps, self.main_thread = make_steps, main_thread
        self.poll_timeout, self.title = poll_timeout, title
        self._holding = holding
        self._thread = None
        self._stop = None

    def __iter__(self):
        if not self.main_thread:
            return (yield from self._relayed())
        try:
            return (yield from self.make_steps())
        finally:  # the device was closed here, with its steps
            self._let_go()

    def _let_go(self):
        held, self._holding = self._holding, None
        if held is not None:
            held.release()

    def _relayed(self):
        import queue
        import threading

        messages, box = queue.Queue(), {}
        stop = self._stop = threading.Event()

        def target():
            flush_denormals_here()  # never raises
            steps = self.make_steps()
            try:
                while True:
                    if stop.is_set():
                        steps.close()  # runs the device's cleanup on its own thread
                        return
                    try:
                        messages.put(next(steps))
                    except StopIteration as done:
                        box["result"] = done.value
                        return
            except BaseException as exc:  # handed to the job's thread, raised there
                box["error"] = exc
            finally:  # the device is closed: now its lock may go, even if the job stopped waiting long ago
                self._let_go()

        thread = threading.Thread(target=target, name=f"{THREAD_PREFIX}{self.title}", daemon=True)
        try:
            thread.start()
        except BaseException:
            self._let_go()
            raise
        self._thread = thread
        progress = (0.0, "starting the device")
        try:
            while thread.is_alive() or not messages.empty():
                try:
                    progress = messages.get(timeout=self.poll_timeout) if self.poll_timeout \
                        else messages.get_nowait()
                    while not messages.empty():  # only the latest matters
                        progress = messages.get_nowait()
                except queue.Empty:
                    pass
                yield progress
        finally:
            stop.set()  # a cancel: the worker closes the device at its next step
        if "error" in box:
            raise box["error"]
        return box.get("result")

    def join(self, timeout: float | None = None):
        if self._thread is not None:
            if self._stop is not None:
                self._stop.set()
            self._thread.join(timeout)
