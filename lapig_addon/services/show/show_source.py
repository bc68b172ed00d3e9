"""The one adapter between the add-on's show (services/show/show_plan) and lapig_core's show producer and video writer
(issue 38): everything the add-on needs of them goes through the functions here, so their APIs change in this
module only.

- frames(source): the show's projector frames, in order, as the pixels each projector receives (the quantised
  native frame Export writes: uint8 or uint16, (H, W, 3)), one list per frame with one array per projector.
  A show with morphs or motions takes every frame from lapig_core/show's producer (`show_frames`: morphs and
  motions stylized, adapted and compensated, holds made once; on a rig of several projectors in camera space on
  their joint reach, each frame split among them by the joint solve: lapig_core/show/joint_setup); a show of
  holds and dissolves, or a build without the producer or torch, gets the stored projector images held and
  dissolved here; without the producer a morph plays as a dissolve and motions stand still, and
  `fallback_notes` says so. A stored dissolve is compensated at its keys (lapig_core/show/dissolve: the looks'
  targets mixed in linear light and compensated by the capture's compensator, or jointly for several
  projectors, at 1/4, 1/2 and 3/4) and crossfaded between them in each projector's linear light, the looks' own
  images at its ends; where that cannot be (no torch, a live show that asks for speed:
  compensated_dissolves=False) it is the crossfade of the looks' images, as Export Crossfade makes.
- write(...): the encoder of an export: lapig_core/export/image_sequence (PNG) or lapig_core/export/video, one line
  from codec_problem() for a codec the installed FFmpeg lacks.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ....lapig_core.common.imageio import to_bit_depth
from ....lapig_core.export.result_files import read_output_image
from ....lapig_core.optics.projector_model import quantised_frame
from ..jobs import JobCancelled
from .show_plan import ShowPlan
from ..state import JOINT, PROJECTOR_SPACE, strategy_for


def _core_model():
    """lapig_core/show/model (Show, Look, Motion, Transition; torch-free), or None where this build lacks it."""
    try:
        from ....lapig_core.show import model
    except ImportError:
        return None
    return model


def _core_frames():
    """lapig_core/show/frames (the per-frame producer: show_frames, ShowSetup; it needs torch), imported when
    first needed."""
    from ....lapig_core.show import frames as core_frames

    return core_frames


# lapig_core/export/codecs.NAMES and the PNG sequence (kept here: a build without the video branch lists them too)
CODECS = ("h264", "h265", "h264-444", "h265-444", "prores422hq", "prores4444", "lossless", "hap", "hap-alpha",
          "hap-q", "png")


@dataclass(frozen=True)
class ShowSource:
    """What the frames are made from: the plan, each projector's model (projector 1 first), the bit depth the
    projectors receive, and the scene's capture (the producer's surface models)."""
    plan: ShowPlan
    projectors: tuple = ()  # lapig_core.optics.projector_model.ProjectorModel per projector
    bit_depth: int = 8
    capture_dir: str = ""
    summaries: dict = field(default_factory=dict, compare=False)  # result folder -> result.json, read once
    use_producer: bool = True  # False: holds and dissolves of the stored images even where the producer is here
    compensated_dissolves: bool = True  # False: dissolves crossfade the looks' images (a live show's 1080p at 30 fps)

    @property
    def frame_count(self) -> int:
        return self.plan.frame_count()

    @property
    def strategy(self) -> str:
        """The rig's model strategy (state.strategy_for): the joint one makes every projector's frames from the
        joint model in the camera's space, then each projector's frame."""
        return strategy_for(len(self.projectors))


def has_producer() -> bool:
    """Whether lapig_core's per-frame producer is here (morphs and motions made per frame)."""
    import importlib.util

    return _core_model() is not None and importlib.util.find_spec("torch") is not None


def needs_producer(plan: ShowPlan) -> bool:
    """Whether the show has frames that are new looks (a morph, a motion). Holds and dissolves are the looks'
    stored projector images (what Export writes of each) and their linear-light crossfades: made here, exactly
    and fast (a live show's 1080p frames at 30 fps)."""
    return any(s.kind == "morph" for s in plan.segments()) or any(look.motion != "none" for look in plan.looks)


def uses_producer(source: "ShowSource") -> bool:
    """Whether the frames of `source` come from lapig_core's producer: a show with morphs or motions, and the
    producer (and torch) here; a rig of several projectors also needs its capture (the joint model)."""
    joint_ready = source.strategy == PROJECTOR_SPACE or bool(source.capture_dir)
    return has_producer() and source.use_producer and joint_ready and needs_producer(source.plan)


def fallback_notes(source: "ShowSource") -> list:
    """What the frames lack without lapig_core's producer ([] with it)."""
    plan = source.plan
    if uses_producer(source) or not needs_producer(plan):
        return []
    why = ("this build has no per-frame show producer (lapig_core/show with torch)" if not has_producer()
           else "the rig of several projectors has no capture" if source.strategy == JOINT
           and not source.capture_dir else "the stored looks were asked for")
    notes = []
    if any(s.kind == "morph" for s in plan.segments()):
        notes.append(f"morphs play as dissolves: {why}")
    if any(look.motion != "none" for look in plan.looks):
        notes.append(f"motions stand still: {why}")
    return notes


def read_summaries(plan: ShowPlan) -> dict:
    from ....lapig_core.export.result_files import read_summary

    return {look.result_dir: read_summary(look.result_dir) for look in plan.looks}


def core_show_of(plan: ShowPlan, summaries: dict):
    """The lapig_core.show.Show of the plan (its looks' prompt, backend and seed from their result.json)."""
    core_show = _core_model()
    looks = []
    for look in plan.looks:
        summary = summaries.get(look.result_dir) or {}
        motion = None if look.motion == "none" else core_show.Motion(look.motion, amount=look.motion_amount,
                                                                      period_s=look.motion_period_s)
        looks.append(core_show.Look(result=look.result_dir, prompt=summary.get("prompt") or "",
                                    backend=summary.get("backend") or "styletransfer", seed=int(summary.get("seed") or 0),
                                    hold_s=look.hold_s, motion=motion))
    transitions = [core_show.Transition(look.transition, seconds=look.transition_s) for look in plan.looks[:-1]]
    return core_show.Show(looks=looks, transitions=transitions, fps=plan.fps)


def frames(source: ShowSource, cancel_event=None, on_progress=None, start: int = 0, stop: int | None = None):
    """(index, [pixels per projector]) for the show's frames start..stop-1 (see the module's text)."""
    plan = source.plan
    problem = plan.problem()
    if problem:
        raise ValueError(problem)
    if not source.projectors:
        raise ValueError("the show needs the rig's projector")
    stop = plan.frame_count() if stop is None else min(stop, plan.frame_count())
    if uses_producer(source):
        yield from _produced(source, cancel_event, on_progress, start, stop)
        return
    yield from _stored(source, cancel_event, on_progress, start, stop)


def _produced(source: ShowSource, cancel_event, on_progress, start: int, stop: int):
    model = source.projectors[0]
    core_frames = _core_frames()
    summaries = source.summaries or read_summaries(source.plan)
    show = core_show_of(source.plan, summaries)
    several = source.strategy == JOINT
    setup = _joint_setup(source, summaries) if several else core_frames.ShowSetup.from_capture(source.capture_dir)
    settings = core_frames.FrameSettings(gamma=model.gamma)  # dissolves in this projector's linear light
    size = None if several else (model.width, model.height)  # several: the camera's, then each projector's frame
    try:
        for index, image in core_frames.show_frames(show, setup, size=size, cancel_event=cancel_event,
                                                  on_progress=on_progress, start=start, stop=stop,
                                                  settings=settings):
            images = image if several else [image]
            yield index, [quantised_frame(im, m.width, m.height, source.bit_depth)
                          for im, m in zip(images, source.projectors)]
    except InterruptedError:  # the producer saw the cancel first
        raise JobCancelled() from None


def _joint_setup(source: ShowSource, summaries: dict):
    """lapig_core/show/joint_setup's setup of the scene's capture of several projectors, at the working size the
    show's first look was made at, each projector's dissolves in its own transfer."""
    from ....lapig_core.show.joint_setup import JointShowSetup, working_size_of

    first = (summaries.get(source.plan.looks[0].result_dir) if source.plan.looks else None) or {}
    setup = JointShowSetup.from_capture(source.capture_dir, working_size=working_size_of(first),
                                        gammas=[m.gamma for m in source.projectors])
    if setup.model.count != len(source.projectors):
        raise ValueError(f"the capture is of {setup.model.count} projectors; the rig has {len(source.projectors)}: "
                         "capture the rig again")
    return setup


def look_images(result_dir: str, count: int) -> list:
    """The stored projector image of a result for each of `count` projectors (a result of one projector: its
    image for the first)."""
    from ....lapig_core.multi.result_files import is_multi_result, projector_images

    if is_multi_result(result_dir):
        images = [image for _, image in projector_images(result_dir)]
        if len(images) != count:
            raise ValueError(f"{result_dir} was made for {len(images)} projectors; the rig has {count}")
        return images
    if count != 1:
        raise ValueError(f"{result_dir} is a look of one projector; the rig has {count}")
    return [read_output_image(result_dir, "projector")]


def _stored(source: ShowSource, cancel_event, on_progress, start: int, stop: int):
    """Holds and dissolves of the stored projector images (the build without lapig_core's producer, and rigs
    of several projectors). Each look is read and quantised once; an 8-bit dissolve frame is one lookup per pixel
    in a 256 x 256 table of the two looks' 8-bit levels mixed in linear light (the 1080p frames of a live show
    come at 30 fps on 2 cores), a 16-bit one is computed in float."""
    plan, models = source.plan, source.projectors
    looks = {}
    dissolve = _stored_dissolve(source)
    keys = {}

    def key(i, j, w):
        """The dissolve's compensated key at weight w, as a stored look per projector (one transition's keys
        kept)."""
        if (i, j, w) not in keys:
            if not any(k[:2] == (i, j) for k in keys):
                keys.clear()
            if len(models) > 1:  # the looks in camera space (look.png), one key frame per projector
                targets = [read_output_image(plan.looks[n].result_dir, "look").astype(np.float32) for n in (i, j)]
                frames = dissolve.key(targets[0], targets[1], w)
            else:
                m = models[0]
                targets = [quantised_frame(read_output_image(plan.looks[n].result_dir, "target"), m.width,
                                           m.height, 16).astype(np.float32) / np.float32(65535) for n in (i, j)]
                frames = [dissolve.key(targets[0], targets[1], w)]
            keys[(i, j, w)] = [_StoredLook(quantised_frame(f, m.width, m.height, 16), m.gamma, source.bit_depth)
                               for f, m in zip(frames, models)]
        return keys[(i, j, w)]

    def look(i):
        if i not in looks:
            images = look_images(plan.looks[i].result_dir, len(models))
            looks[i] = [_StoredLook(quantised_frame(img, m.width, m.height, 16), m.gamma, source.bit_depth)
                        for img, m in zip(images, models)]
        return looks[i]

    total = max(stop - start, 1)
    for index in range(start, stop):
        if cancel_event is not None and cancel_event.is_set():
            return
        segment = plan.segment_at(index)
        if segment.kind == "hold":
            pixels = [stored.pixels for stored in look(segment.a)]
        elif dissolve is not None and segment.kind == "dissolve":
            w = segment.weight(index)
            wa, wb = key_span(w)
            a = look(segment.a) if wa == 0.0 else key(segment.a, segment.b, wa)
            b = look(segment.b) if wb == 1.0 else key(segment.a, segment.b, wb)
            pixels = [x.mixed(y, (w - wa) / (wb - wa)) for x, y in zip(a, b)]
        else:
            w = segment.weight(index)
            pixels = [a.mixed(b, w) for a, b in zip(look(segment.a), look(segment.b))]
        if on_progress is not None:
            on_progress((index - start + 1) / total, f"frame {index + 1} of {plan.frame_count()}")
        yield index, pixels


def _stored_dissolve(source: ShowSource):
    """lapig_core/show/dissolve's StoredDissolve for the source's projector at its native size (several
    projectors: at the camera's, their joint solve), or None where dissolves crossfade the looks' images: asked
    for, no torch, no capture with models, a plan without dissolves."""
    if (not source.compensated_dissolves or not source.capture_dir
            or not has_producer() or not any(s.kind == "dissolve" for s in source.plan.segments())):
        return None
    from ....lapig_core.show.dissolve import StoredDissolve

    core_frames = _core_frames()
    m = source.projectors[0]
    try:
        if source.strategy == JOINT:
            setup = _joint_setup(source, source.summaries or read_summaries(source.plan))
            return StoredDissolve(setup, *setup.output_size)
        setup = core_frames.ShowSetup.from_capture(source.capture_dir)
    except (ValueError, OSError):  # no models: the crossfade (the capture's own blocker says why elsewhere)
        return None
    return StoredDissolve(setup, m.width, m.height)


def key_span(w: float) -> tuple:
    from ....lapig_core.show.dissolve import key_span as span

    return span(w)


class _StoredLook:
    """One projector's frame of a look: its pixels at the bit depth sent, and what a dissolve mixes."""

    def __init__(self, native16: np.ndarray, gamma: float, bit_depth: int):
        self.gamma, self.bit_depth = float(gamma), bit_depth
        self.pixels = to_bit_depth(native16, bit_depth)
        self._linear = None
        self._pairs = {}

    def linear(self) -> np.ndarray:
        if self._linear is None:
            self._linear = np.power(self.pixels.astype(np.float32) / np.float32(2 ** self.bit_depth - 1),
                                    np.float32(self.gamma))
        return self._linear

    def mixed(self, other: "_StoredLook", w: float) -> np.ndarray:
        """The frame at weight w of the crossfade from this look to `other`, mixed in the projector's linear light."""
        if self.bit_depth == 8:
            levels = np.arange(256, dtype=np.float64) / 255.0
            la, lb = levels[:, None] ** self.gamma, levels[None, :] ** other.gamma
            table = to_bit_depth(np.power(la * (1.0 - w) + lb * w, 1.0 / self.gamma), 8).reshape(-1)
            index = self._pairs.get(id(other))
            if index is None:  # the pair's levels, once per transition
                self._pairs = {id(other): (self.pixels.astype(np.uint16) << 8) | other.pixels}
                index = self._pairs[id(other)]
            return np.take(table, index)
        mixed = self.linear() * np.float32(1.0 - w) + other.linear() * np.float32(w)
        return to_bit_depth(np.power(mixed, np.float32(1.0 / self.gamma)), self.bit_depth)


# ------------------------------------------------------------------ the encoder

def _video_module():
    try:
        from ....lapig_core.export import video
    except ImportError:
        return None
    return video


def codec_problem(codec: str) -> str:
    """Why `codec` cannot be written here ('' when it can): one line naming what can."""
    codec = codec.lower()
    if codec not in CODECS:
        return f"unknown codec '{codec}': use one of {', '.join(CODECS)}"
    if codec == "png":
        return ""
    video = _video_module()
    if video is None:
        return f"{codec} needs the video export (lapig_core/export/video), which this build lacks: use --codec png"
    from ....lapig_core.export import codecs as codec_table

    try:
        codec_table.check_codec(codec)
    except ValueError as exc:
        return str(exc)
    return ""


def output_path(out_dir: str, codec: str, projector: int, count: int, name: str = "show") -> str:
    """Where projector `projector` (0-based) of `count` goes in `out_dir`: a folder of PNGs, or a video file."""
    suffix = f"_{projector + 1}" if count > 1 else ""
    if codec == "png":
        return os.path.join(out_dir, f"{name}{suffix}")
    from ....lapig_core.export import codecs as codec_table

    return os.path.join(out_dir, f"{name}{suffix}{codec_table.CODECS[codec].containers[0]}")


def write(path: str, frames_iter, *, codec: str, fps: float, width: int, height: int, count: int,
          bit_depth: int = 8, sidecar: dict | None = None, cancel_event=None, audio: str | None = None) -> dict:
    """Encode `frames_iter` (pixels, in order) to `path` through the video branch's writers: a PNG sequence folder
    (lapig_core/export/image_sequence) or a video and its sidecar '<name>.json' (lapig_core/export/video).
    Returns {'path', 'frames', 'sidecar'}; a cancel raises JobCancelled."""
    video = _video_module()
    if video is None:
        if codec == "png":  # a build without the video branch's writers
            return write_png_sequence(path, frames_iter, count=count, bit_depth=bit_depth, sidecar=sidecar,
                                      cancel_event=cancel_event)
        raise ValueError(codec_problem(codec))
    from ....lapig_core.export.show_output import Cancelled

    show = (sidecar or {}).get("show")
    metadata = {k: v for k, v in (sidecar or {}).items() if k != "show"}
    try:
        if codec == "png":  # <path>/frame_000001.png ... and sequence.json
            from ....lapig_core.export.image_sequence import write_image_sequence

            written = write_image_sequence(frames_iter, path, fps, bit_depth=bit_depth, cancel_event=cancel_event,
                                           metadata=metadata, size=(width, height), show=show, frame_count=count)
            return {"path": str(written["folder"]), "frames": written["frames"], "sidecar": str(written["sidecar"])}
        written = video.write_video(frames_iter, path, fps, (width, height), codec,
                                    bit_depth=bit_depth, cancel_event=cancel_event,
                                    metadata=metadata, show=show, frame_count=count, audio=audio)
    except Cancelled:
        raise JobCancelled() from None
    return {"path": str(written["video"]), "frames": written["frames"], "sidecar": str(written["sidecar"]),
            "notes": written.get("notes", [])}


FRAME_NAME = "frame_{:04d}.png"  # frame 1 is frame_0001.png: Blender's image sequences count from the file's number


def write_png_sequence(folder: str, frames_iter, *, count: int, bit_depth: int = 8, sidecar: dict | None = None,
                       cancel_event=None) -> dict:
    """Write the frames as frame_0001.png, ... into the new folder `folder` (a Staged one: the caller commits
    it whole); a cancel raises JobCancelled."""
    import json

    from ....lapig_core.common.imageio import encode_png

    os.makedirs(folder, exist_ok=True)
    written = 0
    for pixels in frames_iter:
        if cancel_event is not None and cancel_event.is_set():
            raise JobCancelled()
        with open(os.path.join(folder, FRAME_NAME.format(written + 1)), "wb") as f:
            f.write(encode_png(pixels, bit_depth))
        written += 1
    if written != count:
        raise ValueError(f"the show made {written} frames of {count}")
    if sidecar is not None:
        with open(os.path.join(folder, "show.json"), "w", encoding="utf-8") as f:
            json.dump(sidecar, f, indent=2, default=str)
    return {"path": folder, "frames": written}


class Staged:
    """Outputs written into a scratch folder inside `parent` and moved to their final paths only by commit(): a
    cancel or an error (discard()) leaves the final paths as they were, and no half-written file under them."""

    REPLACED = ".replaced~"

    def __init__(self, parent: str, prefix: str = ".lapig_show_"):
        from ....lapig_core.common.scratch import ScratchFolder

        self.scratch = ScratchFolder(parent, prefix)

    def path(self, name: str) -> str:
        return str(self.scratch.path / name)

    def commit(self, moves: list) -> list:
        """moves: (staged path, final path); each final path replaced whole; returns the final paths."""
        done = []
        try:
            for staged, final in moves:
                old = final + self.REPLACED if os.path.exists(final) else None
                if old:
                    _remove(old)
                    os.rename(final, old)
                try:
                    os.rename(staged, final)
                except BaseException:
                    if old:
                        os.rename(old, final)
                    raise
                done.append((final, old))
        except BaseException:
            for final, old in reversed(done):  # put the previous outputs back
                _remove(final)
                if old:
                    os.rename(old, final)
            raise
        finally:
            self.discard()
        for _, old in done:
            if old:
                _remove(old)
        return [final for final, _ in done]

    def discard(self) -> None:
        self.scratch.remove()


def _remove(path: str) -> None:
    import shutil

    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path, ignore_errors=True)
    elif os.path.exists(path):
        os.remove(path)


def frame_bytes_estimate(width: int, height: int, bit_depth: int, codec: str) -> int:
    """About how many bytes one frame takes on disk (PNG and lossless: half the raw pixels; video: less)."""
    raw = width * height * 3 * (2 if bit_depth == 16 else 1)
    big = ("prores4444", "prores422hq", "hap", "hap-alpha", "hap-q")
    return raw // 2 if codec in ("png", "lossless") else raw // 4 if codec in big else raw // 50


def disk_problem(folder: str, frame_bytes: int, count: int) -> str:
    """Why `count` frames of about `frame_bytes` bytes do not fit on `folder`'s disk ('' when they do)."""
    try:
        free = disk_free(folder)
    except OSError:
        return ""
    need = int(frame_bytes) * int(count)
    if need > free:
        return (f"the show needs about {need / 1e9:.2f} GB and {folder} has {free / 1e9:.2f} GB free: "
                f"free some space or choose another folder")
    return ""


def disk_free(folder: str) -> int:
    import shutil

    probe = os.path.abspath(folder)
    while not os.path.exists(probe) and os.path.dirname(probe) != probe:
        probe = os.path.dirname(probe)
    return shutil.disk_usage(probe).free
