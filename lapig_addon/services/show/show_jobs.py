"""The show's jobs (issue 38), on plain objects: Bake Show (the previz's PNG frames per projector, into the .blend's
data folder) and Export Show (a video or a PNG sequence per projector, through the video writer). Both are worker
jobs: the frames are made and encoded on the worker thread, written into a scratch folder and moved to their final
names only at the end, so a cancel or a failure leaves nothing half-written (and the previous output as it was).
Playing the show live is rigs/live_output.ShowPlayJob."""
from __future__ import annotations

import os

from . import show_fanout, show_source
from ..jobs import JobCancelled, WorkerJob
from .show_source import ShowSource


def _notes(source: ShowSource) -> list:
    return show_source.fallback_notes(source)


def _one_line_problem(source: ShowSource) -> str:
    return source.plan.problem()


def sidecar(source: ShowSource, extra: dict | None = None) -> dict:
    """What a show's files say of it: the show (looks, times, transitions, motions, frame rate), the bit depth,
    and the producer's own show description where it is here."""
    out = {"show": source.plan.to_dict(), "bit_depth": source.bit_depth,
           "projectors": [{"index": k + 1, "resolution": [m.width, m.height]} for k, m in enumerate(source.projectors)],
           "producer": "lapig_core.show" if show_source.uses_producer(source) else "stored looks (holds and dissolves)",
           "notes": _notes(source)}
    return {**out, **(extra or {})}


def _write_each(source: ShowSource, writers: list, report, cancel_event) -> list:
    """The show's frames made once, each projector's pixels to its writer (services/show/show_fanout), progress
    reported per frame (report raises JobCancelled at a cancel); a cancel seen anywhere is a cancel."""
    count = source.frame_count
    progress = lambda index: report((index + 1) / count, f"frame {index + 1} of {count}")  # noqa: E731
    written = show_fanout.write_each(show_source.frames(source, cancel_event=cancel_event), writers, progress)
    if cancel_event is not None and cancel_event.is_set():  # the frames stopped early at the cancel
        raise JobCancelled()
    return written


class BakeShowJob(WorkerJob):
    """Bake the show's projector frames as PNG sequences (<folder>/projector_<k>/frame_0001.png, ...) for the
    timeline's previz. finish() returns {'folder', 'frames', 'key'}; the caller wires them into the lights (bpy)."""

    title = "LAPIG bake show"

    def __init__(self, source: ShowSource, folder: str):
        super().__init__()
        self.source, self.folder = source, os.path.abspath(folder)

    def prepare(self):
        problem = _one_line_problem(self.source)
        if problem:
            raise ValueError(problem)
        size = sum(show_source.frame_bytes_estimate(m.width, m.height, self.source.bit_depth, "png")
                   for m in self.source.projectors)
        problem = show_source.disk_problem(os.path.dirname(self.folder), size, self.source.frame_count)
        if problem:
            raise ValueError(problem)
        return self.source

    def work(self, source, report, cancel_event):
        parent = os.path.dirname(self.folder)
        os.makedirs(parent, exist_ok=True)
        staged = show_source.Staged(parent)
        try:
            inside = staged.path("show")
            count = source.frame_count

            def writer(k):
                return lambda frames: show_source.write_png_sequence(
                    os.path.join(inside, f"projector_{k + 1}"), frames, count=count, bit_depth=source.bit_depth,
                    cancel_event=cancel_event)

            _write_each(source, [writer(k) for k in range(len(source.projectors))], report, cancel_event)
            with open(os.path.join(inside, "show.json"), "w", encoding="utf-8") as f:
                import json

                json.dump(sidecar(source), f, indent=2, default=str)
        except BaseException:
            staged.discard()
            raise
        staged.commit([(inside, self.folder)])
        return {"folder": self.folder, "frames": source.frame_count, "key": source.plan.key()}


class ShowExportJob(WorkerJob):
    """Export the show per projector into `out_dir`: show.<ext> (several projectors: show_1, show_2, ...) with a
    show.json sidecar, or PNG sequence folders. Every bad input is refused in prepare(), in one line, before any
    file: a codec the installed FFmpeg lacks, the plan's problems (a frame rate of 0, an empty show), a disk too
    small."""

    title = "LAPIG export show"

    def __init__(self, source: ShowSource, out_dir: str, codec: str, metadata: dict | None = None,
                 name: str = "show", sound: str | None = None, sound_is_temporary: bool = False):
        super().__init__()
        self.source, self.out_dir, self.codec = source, os.path.abspath(out_dir), codec.lower()
        self.metadata, self.name = metadata or {}, name
        # the show's sound (a file the scene's sound strips were mixed down into), in every projector's video;
        # a temporary one is removed when the work ends
        self.sound, self.sound_is_temporary = sound, sound_is_temporary

    def discard_sound(self) -> None:
        if self.sound and self.sound_is_temporary:
            import shutil

            shutil.rmtree(os.path.dirname(self.sound), ignore_errors=True)
            self.sound = None

    def prepare(self):
        problem = show_source.codec_problem(self.codec) or _one_line_problem(self.source)
        if problem:
            raise ValueError(problem)
        if self.source.bit_depth not in (8, 16):
            raise ValueError(f"the bit depth must be 8 or 16, got {self.source.bit_depth}")
        if os.path.exists(self.out_dir) and not os.path.isdir(self.out_dir):
            raise ValueError(f"{self.out_dir} is a file, not a folder")
        size = sum(show_source.frame_bytes_estimate(m.width, m.height, self.source.bit_depth, self.codec)
                   for m in self.source.projectors)
        problem = show_source.disk_problem(self.out_dir, size, self.source.frame_count)
        if problem:
            raise ValueError(problem)
        return self.source

    def work(self, source, report, cancel_event):
        try:
            return self._export(source, report, cancel_event)
        finally:
            self.discard_sound()

    def _export(self, source, report, cancel_event):
        import json

        from ....lapig_core.common.locking import LOCK_FILE

        os.makedirs(self.out_dir, exist_ok=True)
        staged = show_source.Staged(self.out_dir)
        try:
            k_all = len(source.projectors)

            def writer(k, model):
                final = show_source.output_path(self.out_dir, self.codec, k, k_all, self.name)
                inside = staged.path(os.path.basename(final))
                meta = sidecar(source, {**self.metadata, "codec": self.codec, "projector": k + 1})
                return lambda frames: show_source.write(
                    inside, frames, codec=self.codec, fps=source.plan.fps, width=model.width, height=model.height,
                    count=source.frame_count, bit_depth=source.bit_depth, sidecar=meta, cancel_event=cancel_event,
                    audio=self.sound)

            written = _write_each(source, [writer(k, m) for k, m in enumerate(source.projectors)], report,
                                  cancel_event)
            outputs = [{"path": os.path.join(self.out_dir, os.path.basename(w["path"])), "frames": source.frame_count}
                       for w in written]
            sidecar_path = os.path.join(self.out_dir, f"{self.name}.json")
            staged_sidecar = staged.path(os.path.basename(sidecar_path))
            if not os.path.exists(staged_sidecar):  # one video's own sidecar (the video writer's) is this one
                with open(staged_sidecar, "w", encoding="utf-8") as f:
                    json.dump(sidecar(source, {**self.metadata, "codec": self.codec,
                                               "files": [os.path.basename(o["path"]) for o in outputs]}),
                              f, indent=2, default=str)
            names = sorted(n for n in os.listdir(staged.path("")) if n != LOCK_FILE)
        except BaseException:
            staged.discard()
            raise
        staged.commit([(staged.path(n), os.path.join(self.out_dir, n)) for n in names])
        # the writer's own lines (a padding, a depth conversion), once each
        video_notes = list(dict.fromkeys(n for w in written for n in w.get("notes", [])))
        if self.sound and self.codec == "png":
            video_notes.append("the scene's sound is not in a PNG sequence: export a video to carry it")
        return {"codec": self.codec, "fps": source.plan.fps, "frames": source.frame_count,
                "outputs": outputs, "sidecar": sidecar_path, "notes": _notes(source) + video_notes}
