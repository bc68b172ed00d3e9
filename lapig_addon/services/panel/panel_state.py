"""What each step shows (done, stale or missing) and what blocks it: the one check of each, behind
the panels, the operators and the jobs. Plain values in (services/state.py), no bpy."""
from __future__ import annotations

import os
import time
from dataclasses import dataclass

from ....lapig_core.common.deps import missing_required
from ..state import JOINT, PROJECTOR_SPACE, GenerateRequest, Rig, SceneState

NEEDS_NO_RESULT = ("ORIGINAL", "PROJECTION")  # preview modes that show no generated image


@dataclass(frozen=True)
class StepStatus:
    state: str  # 'MISSING', 'STALE' or 'DONE'
    text: str  # what the panel shows beside the state's icon


def rig_blocker(rig: Rig) -> str:
    """Why the rig cannot be captured, rendered or previewed ('' when it can)."""
    if rig.projector is None or rig.camera is None:
        return "Add the projector and camera first"
    if rig.target is None:
        return "Choose the surface object (the mesh to project on)"
    if rig.outside_scene:
        return f"'{rig.outside_scene[0]}' is not in the scene '{rig.scene}'"
    return ""


def device_blocker(rig: Rig) -> str:
    """Why the rig's devices cannot be opened (a capture, a check): rig_blocker, or what a real rig's
    installer must still choose, or why its projectors cannot be captured together ('' when they can)."""
    return rig_blocker(rig) or rig.devices_problem or projectors_blocker(rig)


def projectors_blocker(rig: Rig) -> str:
    """Why the rig's projectors cannot be captured together ('' when they can): a real rig opens one window per
    display (rigs/real_rig.multi_display_problem says the same where the rig opens). Rig.displays are the
    displays of a real rig's projectors beyond the first (none for one projector: its display is the rig's own,
    which devices_problem checks)."""
    if rig.kind != "REAL":
        return ""
    seen = {}
    for name, display in zip(rig.projectors, rig.displays):
        if not display:
            return f"Choose projector '{name}''s display: each projector of a real rig has its own"
        if display in seen:
            return (f"Projectors '{seen[display]}' and '{name}' are both on display '{display}': give each its own "
                    f"display")
        seen[display] = name
    return ""


def one_projector_blocker(rig: Rig) -> str:
    """Why a step of the projector-space strategy alone (one projector's models) cannot run on this rig ('' for
    one projector)."""
    if rig.strategy == PROJECTOR_SPACE:
        return ""
    return f"Works with one projector for now; the rig has {rig.projector_count}"


def _other_rig(state: SceneState) -> bool:
    """The capture was made with another rig than the scene's now (the virtual one and a real one, or two
    real rigs of other names)."""
    return bool(state.capture_rig and state.rig.label and state.capture_rig != state.rig.label)


def _projector_resized(state: SceneState) -> bool:
    return bool(state.capture_projector_size and state.rig.projector_size
                and tuple(state.capture_projector_size) != tuple(state.rig.projector_size))


def _projectors_counted(state: SceneState) -> int:
    """How many projectors the capture was of (a capture of several records each one's coverage)."""
    return len(state.capture_coverage) or 1


def capture_status(state: SceneState) -> StepStatus:
    if not state.capture_dir:
        return StepStatus("MISSING", "No capture yet")
    if state.capture_fingerprint and state.rig.fingerprint and state.rig.fingerprint != state.capture_fingerprint:
        if _other_rig(state):
            return StepStatus("STALE", f"Captured with {state.capture_rig}; the scene now uses {state.rig.label}")
        if state.capture_transport and state.rig.transport and state.capture_transport != state.rig.transport:
            return StepStatus("STALE", f"Captured in {state.capture_transport}; the rig is now {state.rig.transport}")
        if _projectors_counted(state) != state.rig.projector_count:
            return StepStatus("STALE", f"Captured with {_projectors_counted(state)} projector(s); the rig now has "
                                       f"{state.rig.projector_count}")
        if _projector_resized(state):
            (w0, h0), (w1, h1) = state.capture_projector_size, state.rig.projector_size
            return StepStatus("STALE", f"Captured for a {w0}x{h0} projector; it is now {w1}x{h1}")
        if state.rig.kind == "REAL":
            return StepStatus("STALE", "The real rig's display or camera changed since the capture")
        return StepStatus("STALE", "The rig or the object changed since the capture")
    return StepStatus("DONE", state.capture_dir)


def capture_blocker(state: SceneState) -> str:
    """Why the steps after the capture cannot use it yet ('' when they can)."""
    blocker = rig_blocker(state.rig)
    if blocker:
        return blocker
    status = capture_status(state).state
    if status == "MISSING":
        return "Capture the surface first"
    if status == "STALE":
        if _other_rig(state):
            return "Captured with another rig: capture again"
        if state.capture_transport and state.rig.transport and state.capture_transport != state.rig.transport:
            return "The light transport changed: capture again"
        if _projectors_counted(state) != state.rig.projector_count:
            return "The rig's projectors changed: capture again"
        if _projector_resized(state):
            return "The projector's resolution changed: capture again"
        if state.rig.kind == "REAL":
            return "The real rig's display or camera changed: capture again"
        return "The rig or the object moved: capture again"
    return ""


def torch_blocker() -> str:
    """Why the steps that run the networks (Train, Generate, Render Real Capture, Refine) cannot run here ('' when
    torch imports); Capture, the preview and the exports need no torch."""
    from ..install.torch_install import SLOT

    if SLOT.restart_needed():  # installed, but this session cannot import it (or runs another torch)
        return "Restart Blender to use the torch just installed"
    if any(d.package == "torch" for d in missing_required()):
        if SLOT.running():
            return f"Installing torch: {SLOT.job.progress:.0%} (the add-on preferences show it)"
        return "Install torch (see the add-on preferences)"
    return ""


def capture_deps_blocker() -> str:
    """Why Capture cannot run here ('' when it can): it needs numpy and OpenCV, not torch."""
    missing = [d.package for d in missing_required() if d.package != "torch"]  # numpy, OpenCV
    if missing:
        return f"Install {', '.join(missing)} (see the add-on preferences)"
    return ""


def capture_button_blocker(state: SceneState) -> str:
    """Why the Capture button is off ('' when it is on): its packages, then the rig."""
    return capture_deps_blocker() or device_blocker(state.rig)


def models_blocker(state: SceneState) -> str:
    return torch_blocker() or capture_blocker(state)


def train_blocker(state: SceneState) -> str:
    """Why Train cannot run: models_blocker, or several projectors (their first look, the joint classical model,
    is fitted at the capture; there are no networks for them)."""
    if state.rig.strategy == JOINT and not models_blocker(state):
        return ("Several projectors use the joint model fitted at the capture: there is nothing to train; Refine on "
                "the Rig corrects what it misses")
    return models_blocker(state)


def single_result_blocker(state: SceneState) -> str:
    """Why the result cannot be rendered or refined on the rig, or previewed in a result mode ('' when it can)."""
    return result_blocker(state) or one_projector_blocker(state.rig)


def render_blocker(state: SceneState) -> str:
    """Why Render Real Capture or Refine on the Rig cannot run ('' when it can): a result, and every projector's
    window on its own display where the rig is real (projectors_blocker; a rig of several shows every
    projector's image at once: services/render/render_joint, refine_joint)."""
    return result_blocker(state) or projectors_blocker(state.rig)


refine_blocker = render_blocker  # Refine shows and captures the images on the rig as Render does


def models_status(state: SceneState) -> StepStatus:
    if not state.models_fingerprint:
        if state.models_status.startswith("First look"):  # Capture fitted the classical model: Generate works now
            return StepStatus("MISSING", state.models_status)
        return StepStatus("MISSING", "Not trained for this capture (Generate trains them too)")
    if state.models_fingerprint != state.capture_fingerprint:
        return StepStatus("STALE", "Trained for an older capture")
    return StepStatus("DONE", state.models_status or "Fine-tuned for this capture")


_AVAILABILITY: dict = {}  # (backend, options) -> (checked at, available, reason): draw() runs on every redraw


DIFFUSION_BACKENDS = ("one-step", "instruct-pix2pix")  # the looks the one-step preview stands for


def fast_path_problem(backend: str, model_folder: str) -> str:
    """Why typing makes no preview (services/generate/prompt_preview; '' : it does): no one-step model ready, or a look
    that is not a diffusion one."""
    if not model_folder:
        return "the one-step model (SD-Turbo) is not ready in the add-on preferences"
    if backend not in DIFFUSION_BACKENDS:
        return f"the '{backend}' look has no one-step preview (choose 'one-step' or 'instruct-pix2pix')"
    return ""


def fast_path_line(request: GenerateRequest) -> str:
    """The Stylize panel's line where the prompt's preview follows the typing ('' where it does not)."""
    if fast_path_problem(request.backend, request.one_step_model):
        return ""
    return "The projector previews the prompt as you type (SD-Turbo, no PSA); Generate makes the result with PSA"


def backend_warning(request: GenerateRequest) -> str:
    """Why the request's backend cannot run here ('' when it can); Generate then falls back."""
    options = request.backend_options()
    backend = request.lgst_backend()
    key = (backend, tuple(sorted(options.items())))
    checked = _AVAILABILITY.get(key)
    if checked is None or time.monotonic() - checked[0] > 30:
        try:
            from ....lapig_core.lgst import backend_class

            ok, why = backend_class(backend).availability(**options)
        except (ImportError, ValueError) as exc:  # torch missing, or a backend name nothing registered
            ok, why = False, str(exc)
        checked = _AVAILABILITY[key] = (time.monotonic(), ok, why)
    return "" if checked[1] else checked[2]


def generate_blocker(state: SceneState, request: GenerateRequest) -> str:
    return models_blocker(state) or request.problem()


def result_status(state: SceneState) -> StepStatus:
    if not state.result_dir:
        return StepStatus("MISSING", "No projector image yet")
    if state.result_fingerprint and state.rig.fingerprint not in ("", state.result_fingerprint):
        if _other_rig(state):
            return StepStatus("STALE", f"Made with {state.capture_rig}; the scene now uses {state.rig.label}")
        if state.rig.kind == "REAL":
            return StepStatus("STALE", "The real rig changed since this result")
        return StepStatus("STALE", "The rig moved since this result")
    return StepStatus("DONE", os.path.basename(state.result_dir))


def result_blocker(state: SceneState) -> str:
    """Why the result cannot be rendered, compared or exported ('' when it can)."""
    return rig_blocker(state.rig) or ("" if state.result_dir else "Generate a projector image first")


def preview_blocker(state: SceneState, mode: str) -> str:
    """Why the object cannot show preview `mode` yet ('' when it can). A rig of several projectors casts every
    projector's image at once (Projection) and its result's camera-space images from the rig's camera."""
    if mode in NEEDS_NO_RESULT:
        return rig_blocker(state.rig)
    if state.rig.strategy == JOINT:  # the result's images are the camera's: cast from it, missing ones said where read
        return result_blocker(state) or ("" if state.rig.camera else "the rig has no camera to show its images from")
    return result_blocker(state)
