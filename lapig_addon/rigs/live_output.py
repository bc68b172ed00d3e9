"""Live output: the current look on the real projector's window (services/ports.ResultSink), and a
crossfade between two looks played at a set frame rate.

The window (lapig_core.rig.projector_window) stays open between looks: every Generate that has this
sink among its seams replaces the picture, so an artist types a new prompt and sees it on the object.
Esc in the window closes it; the next show() then says so.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from ...lapig_core.common.imageio import to_uint8
from ...lapig_core.rig import RigError
from ..services.float_mode import flush_denormals_here
from ..services.jobs import WorkerJob
from ..services.ports import ProjectorFrame


def size_problem(width: int, height: int, size) -> str:
    """Why a look of width x height cannot be shown 1:1 on a display of ``size`` ('' when it can)."""
    if (width, height) == tuple(size):
        return ""
    return (f"the look is {width}x{height} but the projector's display is {size[0]}x{size[1]}: set the "
            f"projector's resolution to the display's, then Generate")


def window_pixels(frame: ProjectorFrame, size) -> np.ndarray:
    """The 8-bit pixels the window shows of a frame: the quantised_frame that Export writes (a 16-bit
    export shows its top 8 bits); RigError where the look was made for another resolution."""
    problem = size_problem(frame.width, frame.height, size)
    if problem:
        raise RigError(problem)
    return to_uint8(frame.pixels)


class ProjectorWindowSink:
    """Shows each generated frame on an open projector window; `shown_at` is when the last one was on screen.

    A look that cannot be shown (the window was closed, or it is another resolution) does not undo the
    Generate that made it: `problem` says why, for the panel and the command line."""

    several_projectors = False  # Generate hands it projector 1's frame only

    def __init__(self, window):
        self.window = window
        self.shown_at: float | None = None
        self.problem = ""

    @property
    def windows(self) -> list:
        """The windows it shows on, one per projector it drives."""
        return [self.window]

    def player(self, clock=time):
        """play()'s window: one frame at a time."""
        return self.window

    def show(self, frame: ProjectorFrame) -> None:
        try:
            self.shown_at = self.window.show(window_pixels(frame, self.window.size))
            self.problem = ""
        except RigError as exc:
            self.problem = str(exc)


_LIVE: list = []  # the live windows open in this Blender (or command), newest last
_CLOSED = {"note": ""}  # why the last window went away without close_live() (Esc), for the panel
CLOSED_NOTE = "The projector window was closed (Esc or its close button)"


def open_live(display, window_factory=None) -> ProjectorWindowSink:
    """Open the projector window on ``display`` (closing a live one first) and make it a sink of every job.
    This waits for the window's helper process (seconds): Blender's UI opens it with OpenWindowJob."""
    close_live()
    if window_factory is None:
        from ...lapig_core.rig.projector_window import ProjectorWindow as window_factory
    return make_live(ProjectorWindowSink(window_factory(int(display) if str(display).strip().isdigit() else display)))


def make_live(sink: ProjectorWindowSink) -> ProjectorWindowSink:
    """The sink of an open window becomes the live one (a live one before it is closed)."""
    close_live(wait=False)
    _CLOSED["note"] = ""
    _LIVE.append(sink)
    return sink


def close_live(wait: bool = True) -> None:
    """Close the live windows. wait=False: they are forgotten now and closed on a worker thread (a helper
    process takes about a second to end, too long for Blender's main thread)."""
    while _LIVE:
        close_window(_LIVE.pop().window, wait)
    _CLOSED["note"] = ""


def close_window(window, wait: bool = True) -> None:
    if wait:
        window.close()
    else:
        threading.Thread(target=window.close, name="LAPIG: closing the projector window", daemon=True).start()


def open_sinks() -> tuple:
    """The live windows still open (one closed with Esc is forgotten, and status_lines says so)."""
    gone = [sink for sink in _LIVE if not getattr(sink.window, "is_open", True)]
    if gone:
        _LIVE[:] = [sink for sink in _LIVE if sink not in gone]
        _CLOSED["note"] = CLOSED_NOTE
    return tuple(_LIVE)


def status_lines() -> list:
    """The panel's lines about the live window, as (text, ok): where it is open, and why a look was not shown."""
    lines = []
    for sink in open_sinks():
        if isinstance(sink, LockedWindowsSink):
            shown = [w.describe().get("display", {}) for w in sink.window.windows]
            where = (" on displays " + ", ".join(str(d["index"]) for d in shown)) if all("index" in d for d in shown) \
                else ""
            lines.append((f"Showing {len(shown)} projectors{where}, presented together (Esc in one closes it)", True))
        else:
            describe = getattr(sink.window, "describe", None)  # a test's window may not say: its size is enough
            display = describe().get("display", {}) if describe else {}
            w, h = sink.window.size
            where = f"display {display['index']} '{display['name']}'" if "index" in display else "the projector"
            lines.append((f"Showing on {where}, {w}x{h} (Esc closes it)", True))
        if sink.problem:
            lines.append((sink.problem, False))
    if not lines and _CLOSED["note"]:
        lines.append((_CLOSED["note"], None))
    return lines


def play(window, frames, fps: float = 30.0, clock=time, on_frame=None, ahead: int = 4) -> dict:
    """Show ``frames`` (8- or 16-bit (H, W, 3) pixels) one per 1/fps seconds; {"frames", "seconds",
    "late_frames"}: a frame shown more than half a period after its time was late (a slow machine or a
    large frame)."""
    period = 1.0 / float(fps)
    late = shown = 0
    made = _ahead(frames, ahead)  # the next frames are made while this one is on screen
    start = None  # the show's clock starts with its first frame (reading the looks is no lateness)
    for i, pixels in enumerate(made):
        if start is None:
            start = clock.perf_counter()
        due = start + i * period
        wait = due - clock.perf_counter()
        if wait > 0:
            clock.sleep(wait)
        # a 16-bit frame shows its top 8 bits; a list is one frame per projector window (LockedTogether)
        on_screen = window.show([to_uint8(p) for p in pixels] if isinstance(pixels, list) else to_uint8(pixels))
        late += on_screen - due > period / 2
        shown += 1
        if on_frame is not None:
            on_frame(i, on_screen)
    seconds = clock.perf_counter() - start if start is not None else 0.0
    return {"frames": shown, "seconds": round(seconds, 3), "late_frames": int(late)}


def _ahead(frames, depth: int = 4):
    """``frames`` made on a worker thread, up to ``depth`` ahead of the one being shown."""
    import queue

    made: queue.Queue = queue.Queue(maxsize=depth)
    done, failed = object(), []
    stop = threading.Event()

    def put(item) -> bool:
        while not stop.is_set():  # a player that stopped early takes nothing more
            try:
                made.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def produce():
        try:
            flush_denormals_here()
            for frame in frames:
                if not put(frame):
                    return
        except Exception as exc:  # handed to the player
            failed.append(exc)
        put(done)

    worker = threading.Thread(target=produce, name="LAPIG: crossfade frames", daemon=True)
    worker.start()
    try:
        while True:
            frame = made.get()
            if frame is done:
                if failed:
                    raise failed[0]
                return
            yield frame
    finally:
        stop.set()


def identification_frame(size, border: int = 8) -> np.ndarray:
    """What the window shows before there is a look: mid gray inside a white border, so the installer sees
    which display it is on and where the projection's edges fall."""
    w, h = size
    frame = np.full((h, w, 3), 255, np.uint8)
    b = max(1, min(border, w // 4, h // 4))
    frame[b:h - b, b:w - b] = 128
    return frame


class _Stopped(Exception):
    pass


def windows_problem(sink, sizes, whose: str = "the rig") -> str:
    """Why frames of `sizes` (each projector's (width, height), of `whose` projectors) cannot play on the sink's
    windows, one per projector ('' when they can)."""
    windows = sink.windows
    if len(sizes) != len(windows):
        return f"{whose} has {len(sizes)} projectors but {len(windows)} window(s) are open: Show on Projector again"
    for k, (size, window) in enumerate(zip(sizes, windows)):
        problem = size_problem(size[0], size[1], window.size)
        if problem:
            return f"projector {k + 1}: {problem}" if sink.several_projectors else problem
    return ""


def skew_figures(played: dict, window, fps: float, several: bool) -> dict:
    """play()'s figures; the windows of several add the largest spread of one frame's presentations, in frames."""
    if several:
        played["max_skew_frames"] = round(window.max_skew_s * float(fps), 4)
    return played


class CrossfadeJob(WorkerJob):
    """Play a result's crossfade on the open projector window at ``fps``, on a worker thread (Esc in
    Blender stops it; the window keeps the frame it was showing). A result of several on the windows of several
    (a LockedWindowsSink): each projector's crossfade on its own window (services/export/crossfade), every frame
    presented together; the figures add `max_skew_frames`."""

    title = "LAPIG crossfade"

    def __init__(self, sink, store, folder: str, frames: int, fps: float, bit_depth: int = 8):
        super().__init__()
        self.sink, self.store, self.folder = sink, store, folder
        self.frames, self.fps, self.bit_depth = frames, fps, bit_depth

    def prepare(self):
        from ...lapig_core.multi.result_files import is_multi_result
        from ..services.export import crossfade

        several = self.sink.several_projectors
        if is_multi_result(self.folder) != several:  # the result's images and the windows open: one each or one
            raise ValueError("the windows of several are open but the result is of one projector: Generate first"
                             if several else "the result has several projectors but one window is open: Show on "
                             "Projector again")
        if several:
            sizes = crossfade.sizes(self.folder)
        else:
            model = self.store.projector_model()
            sizes = [(model.width, model.height)]
        problem = windows_problem(self.sink, sizes, "the result")
        if problem:
            raise ValueError(problem)
        sets = crossfade.frame_sets(self.store, self.folder, self.bit_depth, self.frames)
        return sets if several else (frame for [frame] in sets)  # one window: its projector's frames

    def work(self, frames, report, cancel_event):
        def on_frame(i, on_screen):
            if cancel_event.is_set():
                raise _Stopped
            report((i + 1) / self.frames, f"frame {i + 1} of {self.frames}")

        window = self.sink.player()
        try:
            played = play(window, frames, self.fps, on_frame=on_frame)
        except _Stopped:
            return None
        return skew_figures(played, window, self.fps, self.sink.several_projectors)


def late_share(played: dict) -> dict:
    """play()'s figures with the late frames as a share of those shown (late_frame_pct, in percent)."""
    frames = played.get("frames") or 0
    return {**played, "late_frame_pct": round(100.0 * played.get("late_frames", 0) / frames, 3) if frames else 0.0}


class ShowPlayJob(WorkerJob):
    """Play the show (services/show/show_source.ShowSource) on the open projector window at the show's frame rate, the
    frames made ahead on a worker thread (play's _ahead); late frames are counted ({'frames', 'seconds',
    'late_frames', 'late_frame_pct'}). Esc in Blender stops it; the window keeps its frame.

    On a rig of several (a LockedWindowsSink) each projector's window shows its own frame of the show, all
    presented together for every frame (LockedTogether), and the figures add `max_skew_frames` (the largest
    spread of one frame's presentations across the windows, in frames of the show's rate)."""

    title = "LAPIG play show"
    AHEAD = 12  # frames made ahead (0.4 s at 30 fps; 75 MB at 1920x1080): a dissolve's first frames or a busy
    # machine's hiccup are absorbed

    def __init__(self, sink, source, fps: float | None = None, clock=time):
        super().__init__()
        self.sink, self.source, self.clock = sink, source, clock
        self.fps = source.plan.fps if fps is None else fps

    def prepare(self):
        problem = self.source.plan.problem()
        if problem:
            raise ValueError(problem)
        if not self.source.projectors:
            raise ValueError("the show needs the rig's projector")
        # one window plays projector 1's frames; the windows of several every projector's
        shown = self.source.projectors if self.sink.several_projectors else self.source.projectors[:1]
        problem = windows_problem(self.sink, [(m.width, m.height) for m in shown])
        if problem:
            raise ValueError(problem)
        return self.source

    def work(self, source, report, cancel_event):
        from ..services.show import show_source

        count = source.frame_count

        def on_frame(i, on_screen):
            if cancel_event.is_set():
                raise _Stopped
            report((i + 1) / count, f"frame {i + 1} of {count}")

        made = show_source.frames(source, cancel_event=cancel_event)
        several = self.sink.several_projectors
        window = self.sink.player(self.clock)
        pixels = (list(frame) if several else frame[0] for _, frame in made)
        try:
            played = late_share(play(window, pixels, self.fps, clock=self.clock, on_frame=on_frame,
                                     ahead=self.AHEAD))
        except _Stopped:
            return None
        return skew_figures(played, window, self.fps, several)


class LockedTogether:
    """A LockedWindowsSink as play()'s one window: show(one frame per projector) presents them together and
    answers the latest present time on the player's clock (the windows answer time.monotonic; the offset to
    clock.perf_counter is taken at each frame). The sink keeps the frames, so a look shown after the show on
    one projector leaves the others' frames as they are."""

    def __init__(self, sink, clock=time):
        self.sink, self.clock = sink, clock
        self.max_skew_s = 0.0

    def show(self, frames) -> float:
        times = self.sink.window.show(frames)
        offset = self.clock.perf_counter() - time.monotonic()
        self.sink.frames = list(frames)
        skew = max(times) - min(times)
        self.max_skew_s = max(self.max_skew_s, skew)
        self.sink.shown_at, self.sink.skew_frames = max(times), skew * self.sink.fps
        return max(times) + offset


@dataclass(frozen=True)
class StoredLook:
    """The result the window shows first, named on Blender's main thread and read on the worker: its folder ('':
    none yet, the identification frame), the projector's native size and the export's bit depth."""
    folder: str = ""
    width: int = 0
    height: int = 0
    bit_depth: int = 8

    def frame(self) -> ProjectorFrame | None:
        if not self.folder:
            return None
        from ...lapig_core.export.result_files import read_output_image

        return ProjectorFrame(read_output_image(self.folder, "projector"), self.width, self.height, self.bit_depth,
                              folder=self.folder)


class OpenWindowJob(WorkerJob):
    """Open the projector window on a worker thread (its helper process takes up to 20 s to start), show the
    look on it and make it the live window (finish(), on the main thread). A cancel ends the job at once; a
    window that opens after it is closed, never live."""

    title = "LAPIG projector window"
    opening, showing = "opening the projector window on display {}", "showing the look"

    def __init__(self, display: str, look: StoredLook = StoredLook(), window_factory=None):
        """window_factory(display): a ProjectorWindow on that display by default (the panel passes the real
        rig's hook, rigs/real_rig._projector_window, which tests replace)."""
        super().__init__()
        self.display, self.look, self.window_factory = str(display), look, window_factory
        self._lock = threading.Lock()
        self._unclaimed = None  # the window opened, until finish() makes it live or a cancel closes it

    def work(self, inputs, report, cancel_event):
        report(0.05, self.opening.format(self.display))
        look = self.look.frame()  # read first: a result that cannot be read opens no window
        window = self._open()
        with self._lock:
            self._unclaimed = window
        if cancel_event.is_set():
            self._close_unclaimed(wait=True)
            return None
        try:
            report(0.9, self.showing)
            return self._shown(window, look)
        except BaseException:
            self._close_unclaimed(wait=True)
            raise

    def _shown(self, window, frame):
        """The window's sink, showing the look (the identification frame before there is one)."""
        sink = ProjectorWindowSink(window)
        if frame is None:
            window.show(identification_frame(window.size))
        else:
            sink.show(frame)
        return sink

    def finish(self, sink):
        with self._lock:
            self._unclaimed = None
        return make_live(sink)

    def cancel(self):
        super().cancel()  # the worker is told: a window it opens from now on, it closes itself
        self._close_unclaimed(wait=False)

    def _open(self):
        if self.window_factory is None:
            from ...lapig_core.rig.projector_window import ProjectorWindow

            return ProjectorWindow(int(self.display) if self.display.strip().isdigit() else self.display)
        return self.window_factory(self.display)

    def _close_unclaimed(self, wait: bool):
        with self._lock:
            window, self._unclaimed = self._unclaimed, None
        if window is not None:
            close_window(window, wait)


# ------------------------------------------------------------------ several projectors (issue 36)
def result_frames(folder: str, bit_depth: int) -> list:
    """A result of several projectors as each projector's ProjectorFrame (result.json's projectors[k].image at
    its native size, what Export writes), in order."""
    from ...lapig_core.export.result_files import read_summary
    from ...lapig_core.multi.result_files import projector_images

    summary = read_summary(folder)
    return [ProjectorFrame(image, *entry["size"], bit_depth, folder=folder, summary=summary, projector_index=k)
            for k, (entry, image) in enumerate(projector_images(folder))]


class LockedWindowsSink:
    """Every projector's window of a rig of several (lapig_core.rig.frame_lock.LockedWindows): each frame of
    a projector replaces its picture, and all the windows present together; `skew_frames` is the last
    presentation's spread between the windows, in frames at `fps`."""

    several_projectors = True  # Generate hands it each projector's frame

    def __init__(self, windows, fps: float = 60.0):
        self.window = windows  # the LockedWindows: size, is_open, describe and close, as one window's
        self.fps = fps
        self.frames = [identification_frame(w.size) for w in windows.windows]
        self.shown_at: float | None = None
        self.skew_frames: float | None = None
        self.problem = ""

    @property
    def windows(self) -> list:
        return self.window.windows

    def player(self, clock=time):
        """play()'s window: a frame per projector, presented together."""
        return LockedTogether(self, clock)

    def show(self, frame: ProjectorFrame) -> None:
        self.show_all([frame])

    def show_all(self, frames) -> None:
        """Each frame on its projector's window (ProjectorFrame.projector_index), presented together."""
        try:
            for frame in frames:
                k = frame.projector_index or 0
                if k >= len(self.frames):
                    raise RigError(f"the look has a projector {k + 1}; {len(self.frames)} windows are open")
                self.frames[k] = window_pixels(frame, self.window.windows[k].size)
            times = self.window.show(self.frames)
            self.shown_at, self.skew_frames = max(times), (max(times) - min(times)) * self.fps
            self.problem = ""
        except RigError as exc:
            self.problem = str(exc)


def open_windows(displays, window_factory=None, names=None):
    """A window on each display at once (each helper starts in a thread of its own: seconds, not K times that);
    LockedWindows of them, or RigError naming the display that failed, the others closed."""
    from ...lapig_core.rig.frame_lock import LockedWindows

    return LockedWindows(open_each(displays, window_factory), names=names or [f"display {d}" for d in displays])


def open_each(displays, window_factory=None) -> list:
    """A window on each display (window_factory(display)), every helper started at once; the first failure
    raised once every window is waited for, those that opened closed."""
    from concurrent.futures import ThreadPoolExecutor

    if window_factory is None:
        from ...lapig_core.rig.projector_window import ProjectorWindow

        def window_factory(display):
            return ProjectorWindow(int(display) if str(display).strip().isdigit() else display)
    displays = [str(d) for d in displays]
    seen = {}
    for k, display in enumerate(displays):
        if display.strip() in seen:
            raise RigError(f"projectors {seen[display.strip()] + 1} and {k + 1} are both on display '{display}': "
                           f"give each its own display")
        seen[display.strip()] = k
    with ThreadPoolExecutor(max_workers=len(displays), thread_name_prefix="LAPIG opening") as pool:
        futures = [pool.submit(window_factory, d) for d in displays]
    opened, failed = [], None
    for future in futures:
        try:
            opened.append(future.result())
        except Exception as exc:  # every window is waited for: none is left open behind a failure
            failed = failed or exc
    if failed is not None:
        for window in opened:
            close_window(window)
        raise failed
    return opened


@dataclass(frozen=True)
class StoredLooks:
    """A result of several projectors as the windows show it first ('' folder: the identification frames)."""
    folder: str = ""
    bit_depth: int = 8

    def frame(self) -> list:
        """Every projector's frame (StoredLook.frame's for several), or none."""
        return result_frames(self.folder, self.bit_depth) if self.folder else []


class OpenWindowsJob(OpenWindowJob):
    """Show on Projector for a rig of several: every projector's window opens at once, on its display, on the
    job's worker thread, each showing its own image of the result; the windows present together."""

    opening, showing = "opening the projector windows on displays {}", "showing the look on every projector"

    def __init__(self, displays, looks: StoredLooks = StoredLooks(), window_factory=None, names=None):
        super().__init__(", ".join(str(d) for d in displays), looks, window_factory)
        self.displays, self.names = [str(d) for d in displays], names

    def _open(self):
        return open_windows(self.displays, self.window_factory, self.names)

    def _shown(self, windows, frames):
        sink = LockedWindowsSink(windows)
        if frames:
            sink.show_all(frames)
            if sink.problem:
                raise RigError(sink.problem)
        else:
            windows.show(sink.frames)
        return sink
