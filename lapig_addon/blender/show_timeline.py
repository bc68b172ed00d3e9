"""The show on Blender's timeline (issue 38): its markers, its range, and its baked projector frames wired into each
projector light as an image sequence, so scrubbing and rendering the animation show it with no add-on code.

The markers are one per look's start, named after the look, and one per transition's start ("dissolve 1s to B");
the show rewrites exactly the markers it wrote last (scene_state.show_markers), so the artist's own stay.
The baked frames are PNGs of the projector's input pixels (what Export writes) referenced relative to the .blend
('//<name>_lapig/shows/show/projector_1/frame_0001.png'): a render farm (Flamenco) that gets the .blend and its
data folder together renders them; the light's nodes turn input into light (projector_nodes.set_projected_sequence).
"""
from __future__ import annotations

import os

import bpy
from bpy.app.handlers import persistent

from ..services.show.show_source import FRAME_NAME
from . import projector_nodes, scene_state, storage
from .operator_boundary import refuse

SEQUENCE_PREFIX = projector_nodes.SHOW_IMAGE_PREFIX


def _timing(scene) -> list:
    """What the markers' frames follow besides the list: the scene's frame rate and first frame."""
    return [scene.render.fps, round(scene.render.fps_base, 6), scene.frame_start]


def rewrite_markers(scene) -> list:
    """Write the show's markers anew (the ones it wrote before go) and set the scene's last frame to the show's
    end; returns the markers [(frame, name)]."""
    plan = scene_state.read_show(scene)
    scene["lapig_show_timing"] = _timing(scene)
    old = set(scene_state.show_markers(scene))
    for marker in list(scene.timeline_markers):
        if (marker.frame, marker.name) in old:
            scene.timeline_markers.remove(marker)
    markers = plan.markers() if plan.looks and plan.fps > 0 else []
    for frame, name in markers:
        scene.timeline_markers.new(name, frame=frame)
    scene_state.record_show_markers(scene, markers)
    if markers and plan.frame_count() > 0:
        scene.frame_end = plan.frame_end()
    return markers


@persistent
def _follow_the_frame_rate(scene, *_args) -> None:
    """After any change (depsgraph_update_post): a scene with a show whose frame rate or first frame changed gets
    its markers written again (once: then they match)."""
    try:
        if scene.lapig.show_looks and list(scene.get("lapig_show_timing", [])) != _timing(scene):
            rewrite_markers(scene)
    except (AttributeError, TypeError, ReferenceError):  # a scene without the add-on's settings, or going away
        pass


def register():
    if _follow_the_frame_rate not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(_follow_the_frame_rate)
    if rewrite_markers not in scene_state.SHOW_LIST_LISTENERS:  # a look removed or moved
        scene_state.SHOW_LIST_LISTENERS.append(rewrite_markers)


def unregister():
    if _follow_the_frame_rate in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(_follow_the_frame_rate)
    if rewrite_markers in scene_state.SHOW_LIST_LISTENERS:
        scene_state.SHOW_LIST_LISTENERS.remove(rewrite_markers)


def shows_root() -> str:
    return os.path.join(storage.data_root()[0], "shows")


def baked_folder(name: str = "show") -> str:
    """Where Bake Show writes: <the .blend's data folder>/shows/<name>, one projector_<k> folder each."""
    return os.path.join(shows_root(), name)


def projector_folder(folder: str, k: int) -> str:
    return os.path.join(folder, f"projector_{k + 1}")


def wire_previz(scene, folder: str, frame_count: int) -> list:
    """Each projector light projects its baked frames in `folder` from the scene's first frame; returns the
    image datablocks. Their paths are relative to the .blend where it is saved."""
    images = []
    for k, projector in enumerate(scene_state.rig_projectors(scene)):
        first = os.path.join(projector_folder(folder, k), FRAME_NAME.format(1))
        if not os.path.isfile(first):
            raise ValueError(f"the baked show has no frames for projector {k + 1} ({first}): bake it again")
        name = SEQUENCE_PREFIX + projector.name
        image = bpy.data.images.get(name)
        path = bpy.path.relpath(first) if bpy.data.filepath else first
        if image is None:
            image = bpy.data.images.load(first, check_existing=False)
            image.name = name
        image.source = "SEQUENCE"
        image.filepath = path
        image.colorspace_settings.name = "Non-Color"  # the projector's input values; the nodes make light
        image.reload()
        projector_nodes.set_projected_sequence(projector.data, image, frame_count, scene.frame_start,
                                               scene_state.projector_model(projector))
        images.append(image)
    return images


def previz_images(scene) -> list:
    """The image each projector light projects now (None where none)."""
    return [projector_nodes.projected_image(p.data) for p in scene_state.rig_projectors(scene)]


def _starts(scene) -> set:
    """The scene frames the projector lights' sequences start at."""
    starts = set()
    for projector in scene_state.rig_projectors(scene):
        texture = projector.data.node_tree.nodes.get(projector_nodes.TEXTURE_NODE) if projector.data.node_tree else None
        if texture is not None and texture.image is not None and texture.image.source == "SEQUENCE":
            starts.add(texture.image_user.frame_start)
    return starts


def is_wired(scene) -> bool:
    images = previz_images(scene)
    return bool(images) and all(image is not None and image.source == "SEQUENCE" for image in images)


# ------------------------------------------------------------------ the show's jobs, read on the main thread

def show_source(scene, bit_depth: int | None = None, use_producer: bool = True, compensated_dissolves: bool = True):
    """The show of the scene as the jobs take it (services/show/show_source.ShowSource): the plan, every projector's
    model, the export's bit depth (or `bit_depth`), the scene's capture. compensated_dissolves=False: dissolves
    crossfade the looks' images (a live show: no compensation while it plays)."""
    from ..services.show.show_source import ShowSource

    state = scene_state.read(scene)
    models = tuple(scene_state.projector_model(p) for p in scene_state.rig_projectors(scene))
    depth = scene_state.export_settings(scene).bit_depth if bit_depth is None else int(bit_depth)
    return ShowSource(scene_state.read_show(scene), projectors=models, bit_depth=depth,
                      capture_dir=state.capture_dir, use_producer=use_producer,
                      compensated_dissolves=compensated_dissolves)


def blocker(scene) -> str:
    """Why the scene's show cannot be baked, exported or played ('' when it can): services/show/show_plan.show_blocker."""
    from ..services.panel.panel_state import rig_blocker
    from ..services.show.show_plan import show_blocker

    state = scene_state.read(scene)
    return rig_blocker(state.rig) or show_blocker(scene_state.read_show(scene), state)


def _checked(scene) -> None:
    refuse(blocker(scene))


def bake_job(scene, use_producer: bool = True):
    """Bake Show's job (services/show/show_jobs.BakeShowJob), checked: its frames go to baked_folder()."""
    from ..services.show.show_jobs import BakeShowJob

    _checked(scene)
    job = BakeShowJob(show_source(scene, use_producer=use_producer), baked_folder())
    job.check()
    return job


def baked(scene, output: dict) -> list:
    """After Bake Show: the scene records the frames and each projector light projects them."""
    scene_state.record_show_baked(scene, output["folder"], output["key"])
    images = wire_previz(scene, output["folder"], output["frames"])
    if scene_state.read(scene).preview_mode == "PROJECTION":  # the viewport's preview shows the show too
        from . import result_preview

        result_preview.apply_mode(scene, "PROJECTION")
    return images


def previz_status(scene) -> tuple[str, bool | None]:
    """The panel's line about the baked previz: (text, ok) (ok None: nothing baked yet)."""
    plan = scene_state.read_show(scene)
    folder, key = scene_state.show_baked(scene)
    if not folder:
        return "No previz baked yet: Bake Show puts the show on the timeline", None
    if key != plan.key() or _starts(scene) - {scene.frame_start}:
        return "The show changed since it was baked: Bake Show again", False
    wired = "on the projector light" if is_wired(scene) else "baked (not on the light: Bake Show again)"
    return f"Previz {wired}: {plan.frame_count()} frames at {plan.fps:g} fps", is_wired(scene)


def _use_preferred_ffmpeg() -> None:
    """The preferences' ffmpeg (for HAP where PyAV lacks it) as $LAPIG_FFMPEG, which the video writer reads on
    the worker thread (lapig_core/export/codecs.find_ffmpeg)."""
    import os

    from ...lapig_core.export.codecs import FFMPEG_ENV
    from .preferences import ffmpeg_path

    path = ffmpeg_path()
    if path:
        os.environ[FFMPEG_ENV] = path
    else:
        os.environ.pop(FFMPEG_ENV, None)


def sound_strips(scene) -> list:
    """The scene's sound strips that play in its range (not muted)."""
    editor = scene.sequence_editor
    if editor is None:
        return []
    strips = getattr(editor, "strips_all", None)
    if strips is None:
        strips = getattr(editor, "sequences_all", [])
    return [s for s in strips if s.type == "SOUND" and not s.mute
            and s.frame_final_start <= scene.frame_end and s.frame_final_end > scene.frame_start]


def show_sound(scene) -> str | None:
    """The scene's sound over the show's range (the scene's range: the show starts at its first frame), mixed
    down by Blender into a 48 kHz stereo WAV in a new temporary folder; None where no sound strip plays there."""
    import shutil
    import tempfile

    if not sound_strips(scene):
        return None
    folder = tempfile.mkdtemp(prefix="lapig_show_sound_")
    path = os.path.join(folder, "show_sound.wav")
    try:
        done = bpy.ops.sound.mixdown(filepath=path, check_existing=False, relative_path=False, container="WAV",
                                     codec="PCM", format="S16", mixrate=48000, channels="STEREO")
    except RuntimeError as exc:
        done = {str(exc).strip().splitlines()[-1] if str(exc).strip() else "failed"}
    if done != {"FINISHED"} or not os.path.isfile(path):
        shutil.rmtree(folder, ignore_errors=True)
        raise ValueError(f"Blender could not mix the scene's sound down ({', '.join(sorted(done))}): mute the "
                         f"sound strips to export the show without sound")
    return path


def export_job(scene, out_dir: str, codec: str, bit_depth: int | None = None, use_producer: bool = True):
    """Export Show's job (services/show/show_jobs.ShowExportJob), checked before any file is written; the scene's
    sound strips in the show's range go into the video (mixed down here, on the main thread)."""
    from ..services.export.export_source import addon_version
    from ..services.show.show_jobs import ShowExportJob
    from . import scene_store

    _checked(scene)
    _use_preferred_ffmpeg()
    store = scene_store.BlenderSceneStore(scene)
    metadata = {**store.rig_metadata(), **store.software(), "lapig_version": addon_version()}
    source = show_source(scene, bit_depth, use_producer=use_producer)
    sound = show_sound(scene) if codec.lower() != "png" else None
    job = ShowExportJob(source, out_dir, codec, metadata, sound=sound, sound_is_temporary=True)
    try:
        job.check()
    except BaseException:
        job.discard_sound()
        raise
    return job


def play_job(scene, sink, use_producer: bool = True):
    """Play Show's job (rigs/live_output.ShowPlayJob) on the live window's sink, checked."""
    from ..rigs.live_output import ShowPlayJob

    _checked(scene)
    # live: dissolves crossfade the looks' images (1080p frames at 30 fps; a compensated key costs about a second)
    job = ShowPlayJob(sink, show_source(scene, bit_depth=8, use_producer=use_producer, compensated_dissolves=False))
    job.check()
    return job
