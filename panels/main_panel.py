import bpy

from ..lapig_addon.blender import live_devices, scene_state, storage, ui_text, warm_start
from ..lapig_addon.blender.modal_runner import SLOTS, active_job
from ..lapig_addon.rigs import camera_view, device_list, live_output
from ..lapig_addon.services.panel import panel_state
from ..lapig_addon.services.background_jobs import background_line
from ..lapig_addon.services.capture.rig_check import last_check
from ..lapig_core.common.deps import missing_required

STATE_ICONS = {"DONE": "CHECKMARK", "STALE": "ERROR", "MISSING": "DOT"}
LINE_ICONS = {True: "NONE", False: "ERROR", None: "NONE"}  # _lines: fine, a problem, greyed


class LapigPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "LAPIG"


class LAPIG_PT_setup(LapigPanel, bpy.types.Panel):
    bl_label = "Setup"
    bl_idname = "LAPIG_PT_setup"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        s = context.scene.lapig
        warm_start.on_first_use()  # the add-on is used: the text and style models load in the background
        missing = missing_required()
        if missing:
            _lines(layout, fit, [("Missing: " + ", ".join(d.package for d in missing), False),
                                 ("See the add-on preferences", True)])
        layout.prop(s, "rig_kind", expand=True)
        real = s.rig_kind == "REAL"
        layout.prop(s, "target")
        layout.operator("lapig.add_rig", icon="OUTLINER_OB_LIGHT")
        layout.prop(s, "projector")
        layout.prop(s, "camera")
        _projectors(layout, context.scene, real, fit)
        if s.projector:
            p = s.projector.lapig_projector
            col = layout.column(align=True)
            col.label(text="Projector", icon="LIGHT_SPOT")  # its size, lens and light; the camera's below
            _pair(col, p, "resolution_x", "resolution_y")
            col.prop(p, "throw_ratio")
            _pair(col, p, "shift_x", "shift_y")
            _props(col, p, "brightness", "black_level", "gamma")
        if s.projector and not real:  # how Cycles renders the captures: a real rig's are real
            p = s.projector.lapig_projector
            box = layout.box()
            box.prop(p, "transport_mode")
            if p.transport_mode == "REALISTIC":
                _props(box.column(align=True), p, "bounces", "indirect_samples", "indirect_downscale")
                _props(box.column(align=True), p, "lens_radius_mm", "focus_distance")
                if s.camera:
                    c = s.camera.lapig_camera
                    col = box.column(align=True)
                    col.prop(c, "use_dof")
                    sub = col.column(align=True)
                    sub.enabled = c.use_dof
                    sub.prop(c, "focus_distance", text="Camera focus")
                    sub.prop(c, "f_number")
                    col.prop(c, "vignetting")
                box.operator("lapig.focus_on_object", icon="CAMERA_DATA")
        if s.camera and not real:
            c = s.camera.lapig_camera
            col = layout.column(align=True)
            col.label(text="Camera", icon="CAMERA_DATA")
            _pair(col, c, "resolution_x", "resolution_y")
            col.prop(c, "auto_exposure")
            sub = col.column()
            sub.enabled = not c.auto_exposure
            sub.prop(c, "exposure")
            col.prop(c, "response_gamma")
            col.prop(c, "noise")
        if not real:
            layout.prop(s, "ambient")
        if s.target is not None:
            from ..lapig_addon.blender.preview import is_previewing

            on = is_previewing(s.target)
            layout.operator("lapig.preview_toggle", icon="HIDE_OFF" if on else "HIDE_ON",
                            text="Hide Projection Preview" if on else "Preview Projection")


def _projectors(layout, scene, real: bool, fit):
    """The rig's projectors (name, resolution and, once captured, each one's share of the object) and Add
    Projector; a rig of one projector shows the button alone, as it read before."""
    s = scene.lapig
    if s.projector is None:
        return
    if not s.extra_projectors:
        layout.operator("lapig.add_projector", icon="ADD")
        return
    state = scene_state.read(scene)
    captured = panel_state.capture_status(state).state == "DONE"
    shares = dict(state.capture_coverage) if captured else {}
    box = layout.box()
    inner = fit.boxed()
    box.label(text=f"Projectors ({state.rig.projector_count})", icon="LIGHT_SPOT")
    displays = {item.projector.name: item for item in s.extra_projectors if item.projector is not None}
    for k, (name, (w, h)) in enumerate(zip(state.rig.projectors, state.rig.projector_sizes)):
        row = box.row(align=True)
        line = inner
        if k and name in displays:  # Remove beside it (a unit), and a real rig's display field (half the rest)
            line = inner.beside(1).share(2 if real else 1)
        row.label(text=line.head(f"{k + 1}. {name}:", icon=False))
        if k and name in displays:
            if real:
                row.prop(displays[name], "display", text="")
            row.operator("lapig.remove_projector", text="", icon="X").name = name
        share = f", {shares[name]:.0%} of the object" if name in shares else ""
        _lines(box, inner, [(f"{w}x{h}{share}", True)], icon="BLANK1")  # under its name: its size and share
    if shares and state.capture_reach is not None:
        _lines(box, inner, [(f"All together: {state.capture_reach:.0%} of the object", True)])
    _blocked(box, panel_state.projectors_blocker(state.rig), inner)
    if shares:  # a capture of this rig: its blend weights to show
        box.operator("lapig.blend_preview", icon="COLOR")
    box.operator("lapig.add_projector", icon="ADD")


def _lines(layout, fit, lines, icon=None):
    """(text, ok) lines: ok True plain, False with a warning icon, None greyed; each wrapped at the width the
    panel has (fit: blender/ui_text.fit_for), its next lines indented an icon's width (BLANK1: the tests join
    them again). `icon`: the first line's icon instead of ok's."""
    for text, ok in lines:
        first = icon or LINE_ICONS[ok]
        for i, part in enumerate(fit.wrap(text, icon=True, first_icon=first != "NONE")):
            row = layout.row()
            row.enabled = ok is not None
            row.label(text=part, icon=first if i == 0 else "BLANK1")


class LAPIG_PT_real_rig(LapigPanel, bpy.types.Panel):
    bl_label = "Real Projector and Camera"
    bl_idname = "LAPIG_PT_real_rig"
    bl_parent_id = "LAPIG_PT_setup"

    @classmethod
    def poll(cls, context):
        return context.scene.lapig.rig_kind == "REAL"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        scene = context.scene
        r = scene.lapig.real
        state = scene_state.read(scene)
        busy = _job_running()
        found = device_list.found()
        _button(layout, not busy, "lapig.find_devices", icon="VIEWZOOM")
        if found is not None:
            _lines(layout, fit, [(found.summary(), True)] + [(problem, False) for problem in found.problems])
        row = layout.row(align=True)
        row.prop(r, "display")
        row.operator_menu_enum("lapig.choose_display", "display", text="", icon="DOWNARROW_HLT")
        _lines(layout, fit, device_list.display_note(found, r.display, state.rig.projector_size))
        layout.prop(r, "camera_source", expand=True)
        if r.camera_source == "DEVICE":
            row = layout.row(align=True)
            row.prop(r, "camera")
            row.operator_menu_enum("lapig.choose_camera", "camera", text="", icon="DOWNARROW_HLT")
            layout.prop(r, "camera_backend")
            col = layout.column(align=True)
            col.label(text="Picture size (0: the camera's)")
            _pair(col, r, "camera_width", "camera_height")
            for key in scene_state.CAMERA_CONTROLS:
                row = col.row(align=True)
                row.prop(r, "use_" + key, text="")
                sub = row.row(align=True)
                sub.enabled = getattr(r, "use_" + key)
                sub.prop(r, key)
        else:
            layout.prop(r, "tethered_folder")
        layout.prop(r, "name")
        _props(layout.column(align=True), r, "frame_code", "health_checks")
        blocked = _blocked(layout, state.rig.devices_problem, fit)

        box = layout.box()
        inner = fit.boxed()
        _progress(box, other_than=live_output.OpenWindowJob.title)
        _button(box, not blocked and not busy, "lapig.check_rig", icon="CHECKMARK")
        check = last_check(state.rig.fingerprint)
        if check is not None:
            _lines(box, inner, [(line.label(), line.ok) for line in check.lines] + [(p, False) for p in check.problems])

        box = layout.box()
        viewing = live_devices.camera_view_running()
        spec = scene_state.real_rig_spec(scene)
        can_view = not busy and spec is not None and not spec.problem(display=False)
        _button(box, viewing or can_view, "lapig.camera_view", icon="CAMERA_DATA", depress=viewing,
                text="Stop Camera View" if viewing else "Camera View")
        line = camera_view.status()
        if line is not None:
            _lines(box, inner, [line])

        box = layout.box()
        showing = bool(live_output.open_sinks())
        _progress(box, live_output.OpenWindowJob.title)  # its helper takes seconds to start
        _button(box, showing or not busy, "lapig.show_on_projector", icon="WINDOW", depress=showing,
                text="Close Projector Window" if showing else "Show on Projector")
        _lines(box, inner, live_output.status_lines())
        _props(box.column(align=True), scene.lapig, "crossfade_frames", "crossfade_fps")
        _button(box, showing and not busy and not panel_state.result_blocker(state), "lapig.play_crossfade",
                icon="PLAY")


class LAPIG_PT_capture(LapigPanel, bpy.types.Panel):
    bl_label = "Capture"
    bl_idname = "LAPIG_PT_capture"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        s = context.scene.lapig
        state = scene_state.read(context.scene)
        status = panel_state.capture_status(state)
        if status.state == "DONE":  # the capture's folder: its tail ("…/Wall/capture_0001")
            layout.label(text=fit.tail(status.text), icon=STATE_ICONS[status.state])
        else:
            _lines(layout, fit, [(status.text, True)], icon=STATE_ICONS[status.state])
        if state.capture_dir and state.capture_transport:
            _lines(layout, fit, [("Light: " + state.capture_transport, True)], icon="LIGHT_SPOT")
        _props(layout.column(align=True), s, "train_count", "test_count", "working_size", "samples", "gray_level")
        layout.prop(s, "pattern_source", expand=True)
        if s.pattern_source == "FOLDER":
            layout.prop(s, "pattern_folder")
        folder, temporary = storage.data_root()
        if temporary:
            _lines(layout, fit, [(storage.location_message(), False)])
        else:  # where the data goes: the folder's tail
            layout.label(text=fit.tail("Data: " + folder, keep="Data: "), icon="FILE_FOLDER")
        _progress(layout)
        # numpy and OpenCV, not torch (the operator's poll says so in the tooltip); then the rig
        blocked = panel_state.capture_button_blocker(state)
        _button(layout, not blocked and not _job_running(), "lapig.capture", icon="RENDER_STILL")
        _blocked(layout, blocked, fit)
        layout.operator("lapig.import_capture", icon="IMPORT")


def _job_running() -> bool:
    job = active_job()
    return job is not None and not job.finished


def _progress(layout, title=None, other_than=None):
    """The running job's progress bar; with `title`, only that job's (the panel beside its button); with
    `other_than`, any job's but that one's (it has its own bar). A bar is one line, which a narrow sidebar clips:
    the status bar has the whole message too (modal_runner)."""
    job = active_job()
    if job is not None and not job.finished and (title is None or job.title == title) and job.title != other_than:
        layout.progress(factor=job.progress, text=f"{job.message} (Esc to cancel)")


def _button(layout, enabled: bool, idname: str, **kwargs):
    """An operator's button on a row of its own, greyed out unless `enabled`; its properties, to set."""
    row = layout.row()
    row.enabled = enabled
    return row.operator(idname, **kwargs)


def _props(layout, owner, *names):
    """The owner's properties one under the other, in `layout` (an aligned column, most often)."""
    for name in names:
        layout.prop(owner, name)


def _pair(layout, owner, first: str, second: str):
    """Two properties side by side (a width and a height, x and y), on an aligned row."""
    row = layout.row(align=True)
    row.prop(owner, first)
    row.prop(owner, second)


def _blocked(layout, reason, fit):
    """Show why the step below cannot run yet (wrapped at the panel's width); returns True when it cannot."""
    if reason:
        _lines(layout, fit, [(reason, True)], icon="INFO")
    return bool(reason)


class LAPIG_PT_models(LapigPanel, bpy.types.Panel):
    bl_label = "Models"
    bl_idname = "LAPIG_PT_models"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        state = scene_state.read(context.scene)
        status = panel_state.models_status(state)
        _lines(layout, fit, [(status.text, True)], icon=STATE_ICONS[status.state])
        layout.prop(context.scene.lapig, "finetune_iterations")
        blocked = panel_state.train_blocker(state)
        _blocked(layout, blocked, fit)
        _button(layout, not blocked and not _job_running(), "lapig.train_models", icon="SHADERFX",
                text="Fine-tune Again" if status.state == "DONE" else "Train Models")
        layout.prop(context.scene.lapig, "train_in_background")
        _background(layout, fit)


def _background(layout, fit):
    """The Train in the background: its progress and its own Cancel (Esc is the foreground job's), or how it
    failed."""
    line = background_line(SLOTS)
    if line is None:
        return
    text, ok = line
    if SLOTS.background_running():
        row = layout.row(align=True)
        row.progress(factor=SLOTS.background.progress, text=f"{SLOTS.background.progress:.0%}")
        row.operator("lapig.cancel_background_train", icon="CANCEL", text="Cancel")
    _lines(layout, fit, [(text, ok)])


class LAPIG_PT_stylize(LapigPanel, bpy.types.Panel):
    bl_label = "Stylize"
    bl_idname = "LAPIG_PT_stylize"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        s = context.scene.lapig
        state, request = scene_state.read(context.scene), scene_state.generate_request(context.scene)
        status = panel_state.result_status(state)
        _lines(layout, fit, [(status.text, True)], icon=STATE_ICONS[status.state])
        layout.prop(s, "prompt", text="")
        layout.prop(s, "backend")
        warning = panel_state.backend_warning(request)
        if warning:
            _lines(layout, fit, [("Falls back to 'styletransfer': " + warning[:160], False)])
        fast = panel_state.fast_path_line(request)
        if fast:
            _lines(layout, fit, [(fast, True)])
        layout.prop(s, "style_override")
        layout.prop(s, "style_image")
        if s.style_image.strip():
            layout.prop(s, "style_prompt_weight")
        row = layout.split(factor=0.35, align=True)  # the check box's short name, the slider's value
        row.prop(s, "use_psa")
        sub = row.row()
        sub.enabled = s.use_psa
        sub.prop(s, "psa_adaptation")
        layout.prop(s, "style_seed")
        layout.prop(s, "dark_outside")
        layout.prop(s, "output_size")
        _progress(layout)
        blocked = panel_state.generate_blocker(state, request)
        _blocked(layout, blocked, fit)
        row = layout.row()
        row.scale_y = 1.4
        row.enabled = not blocked and not _job_running()
        row.operator("lapig.generate", icon="BRUSH_DATA")
        if scene_state.look_sliders_shown(context.scene):
            _look_sliders(layout, s)


def _look_sliders(layout, s):
    """A world look's few parameters (lapig_core/look_parameters): a change makes the look again once the slider
    rests (blender/look_sliders), without a new prompt."""
    from ..lapig_core.look_parameters import PARAMETERS

    box = layout.box()
    box.label(text="Look", icon="TEXTURE")
    col = box.column(align=True)
    for p in PARAMETERS:
        col.prop(s, f"look_{p.name}")
    row = box.row(align=True)
    row.enabled = not _job_running()
    row.operator("lapig.edit_look", icon="FILE_REFRESH")
    row.operator("lapig.edit_look", text="Reset", icon="LOOP_BACK").reset = True
    box.operator("lapig.look_nodes", icon="NODETREE")


class LAPIG_PT_preview_export(LapigPanel, bpy.types.Panel):
    bl_label = "Preview and Export"
    bl_idname = "LAPIG_PT_preview_export"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        s = context.scene.lapig
        state = scene_state.read(context.scene)
        blocked = panel_state.result_blocker(state)
        has_result = not blocked
        _blocked(layout, blocked, fit)
        if s.result_summary:
            # "what the prompt was read as | which word matched nothing": one line each
            for i, part in enumerate(s.result_summary.split(" | ")):
                _lines(layout, fit, [(part, True)], icon="INFO" if i else None)
        if s.result_reach_message:  # most of the look is out of the surface's reach: say so plainly
            _lines(layout, fit, [(s.result_reach_message, False)])
        col = layout.column()
        col.enabled = not panel_state.rig_blocker(state.rig)
        col.prop(s, "preview_mode", expand=True)
        single = not panel_state.one_projector_blocker(state.rig)  # several: an image each, MPCDI
        # rendering also needs torch and the capture the result was made on; several projectors render together
        render_blocked = has_result and (panel_state.render_blocker(state) or panel_state.models_blocker(state))
        refine_blocked = has_result and (panel_state.refine_blocker(state) or panel_state.models_blocker(state))
        if render_blocked and render_blocked == refine_blocked:  # the result is there: say why these two wait
            _blocked(layout, render_blocked, fit)
        _button(layout, has_result and not render_blocked and not _job_running(), "lapig.render_result",
                icon="RENDER_RESULT")
        if render_blocked and render_blocked != refine_blocked:
            _blocked(layout, render_blocked, fit)
        col = layout.column(align=True)  # closed loop: the rig's captures correct the image (progress; Esc cancels)
        # several projectors are refined together (their joint model): refine_blocker says when
        col.enabled = has_result and not refine_blocked and not _job_running()
        col.operator("lapig.refine_result", icon="FILE_REFRESH")
        col.prop(s, "refine_steps")
        if refine_blocked and render_blocked != refine_blocked:
            _blocked(layout, refine_blocked, fit)
        _progress(layout, "LAPIG refine on the rig")
        _button(layout, has_result, "lapig.show_comparison", icon="IMAGE_REFERENCE")
        layout.separator()
        col = layout.column()
        col.enabled = has_result
        col.prop(s, "export_bit_depth", expand=True)
        col.prop(s, "export_path")
        if single:
            col.operator("lapig.export_image", icon="EXPORT")
            col.prop(s, "crossfade_frames")
            col.operator("lapig.export_crossfade", icon="SEQUENCE")
        else:  # one image per projector (<name>_1.png, ...), and the rig's warps and blends for a media server
            col.operator("lapig.export_image", icon="EXPORT", text="Export Projector Images")
            sub = col.column(align=True)  # the MPCDI profile: '2d' (default) or 'sl' (shader lamp)
            sub.operator("lapig.export_mpcdi", icon="PACKAGE", text="Export MPCDI 2D").profile = "2d"
            sub.operator("lapig.export_mpcdi", icon="PACKAGE", text="Export MPCDI Shader Lamp").profile = "sl"
            col.prop(s, "crossfade_frames")  # a folder per projector, each in its own gamma
            col.operator("lapig.export_crossfade", icon="SEQUENCE")


CLASSES = (LAPIG_PT_setup, LAPIG_PT_real_rig, LAPIG_PT_capture, LAPIG_PT_models, LAPIG_PT_stylize,
           LAPIG_PT_preview_export)

register, unregister = bpy.utils.register_classes_factory(CLASSES)
