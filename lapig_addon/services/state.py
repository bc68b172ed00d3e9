"""The add-on's settings and progress as plain values: what the panels and the jobs decide on.

blender/scene_state.py reads them from scene.lapig and the projector and camera objects (and writes
the jobs' results back); nothing here imports bpy, so the decisions are tested without Blender
(tests/addon).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from ...lapig_core.optics.camera_model import CameraResponse
from .limits import first_problem

PROJECTOR_SPACE = "projector-space"  # Rig.strategy: one projector's models, in its own pixels
JOINT = "joint"  # Rig.strategy: several projectors' joint model, in the camera's pixels

IP2P_BACKEND = "instruct-pix2pix"  # lapig_core.lgst's name for it (not imported here: it needs torch)
ONE_STEP_BACKEND = "one-step"  # the one-step model's look (SD-Turbo), lapig_core/lgst/one_step_backend
ARBITRARY_BACKEND = "arbitrary"  # the reference-image backend, which a chosen style image uses


def overridden(settings, **overrides):
    """`settings` with the caller's explicit values; None means 'not given', so the scene's value stays."""
    return replace(settings, **{name: value for name, value in overrides.items() if value is not None})


@dataclass(frozen=True)
class CameraSettings:
    """A capture camera's LAPIG settings (obj.lapig_camera)."""
    width: int
    height: int
    auto_exposure: bool
    exposure: float  # stops, when auto exposure is off
    response_gamma: float
    noise: float

    def response(self, exposure_stops: float | None = None) -> CameraResponse:
        """The camera's response at `exposure_stops` (default: its manual exposure)."""
        stops = self.exposure if exposure_stops is None else exposure_stops
        return CameraResponse(gamma=self.response_gamma, noise_std=self.noise, exposure_stops=stops)


@dataclass(frozen=True)
class Rig:
    """The scene's projector, camera and surface object, by name: None where one is not set, or is not a
    LAPIG projector, a camera or a mesh."""
    projector: str | None = None
    camera: str | None = None
    target: str | None = None
    scene: str = ""
    outside_scene: tuple[str, ...] = ()  # rig objects that are not linked into the scene
    fingerprint: str = ""  # of the whole rig as it is now (blender/fingerprint.py); '' while incomplete
    projector_size: tuple[int, int] | None = None  # (width, height) of the projector's native frame
    transport: str = ""  # the light transport's label (lapig_core.optics.transport); '' while incomplete
    kind: str = "VIRTUAL"  # 'VIRTUAL' (the Cycles studio of the objects) or 'REAL' (a projector and a camera)
    label: str = "the virtual rig"  # which rig, as a sentence names it: "the real rig 'gallery'"
    devices_problem: str = ""  # what a real rig's installer must still choose (its display, its camera)
    # several projectors (issue 36): every projector's name and (width, height), projector 1 first; with a real
    # rig, each one's display ('' where not chosen). One projector: its own name and size alone.
    projectors: tuple[str, ...] = ()
    projector_sizes: tuple = ()
    displays: tuple[str, ...] = ()

    @property
    def projector_count(self) -> int:
        return len(self.projectors) if self.projectors else int(self.projector is not None)

    @property
    def strategy(self) -> str:
        """The rig's model strategy (strategy_for). Each stage picks its way from this (services/ways.py)."""
        return strategy_for(self.projector_count)


def strategy_for(projector_count: int) -> str:
    """The model strategy of a rig of `projector_count` projectors, chosen here and nowhere else (ARCHITECTURE.md,
    glossary): PROJECTOR_SPACE, the learned CompenNeSt/PCNet or the classical model of one projector (the paper's
    figures), or JOINT, the camera-space joint model of any number of projectors."""
    return JOINT if projector_count > 1 else PROJECTOR_SPACE


@dataclass(frozen=True)
class SceneState:
    """The rig and what the steps left in the scene, read at one moment."""
    rig: Rig = Rig()
    capture_dir: str = ""  # the last capture, found again beside a moved .blend; '' when it is gone
    capture_fingerprint: str = ""  # the rig's fingerprint when it was captured; '' for an imported capture
    capture_transport: str = ""  # the light transport's label when it was captured; '' when unknown
    capture_rig: str = ""  # the rig's label (Rig.label) when it was captured; '' when unknown
    capture_projector_size: tuple[int, int] | None = None  # the projector's (width, height) then; None: unknown
    models_fingerprint: str = ""  # the capture fingerprint the models were fine-tuned for
    models_status: str = ""
    result_dir: str = ""  # the last generated result, found again like the capture
    result_fingerprint: str = ""  # the rig's fingerprint when the result was made
    preview_mode: str = "ORIGINAL"
    # several projectors: each one's share of the object at the last capture, ((name, share), ...), and together
    capture_coverage: tuple = ()
    capture_reach: float | None = None


@dataclass(frozen=True)
class GenerateRequest:
    """What Generate turns into a look: the Stylize panel's settings, or the command line's."""
    prompt: str
    backend: str
    mix: str  # an explicit style mix instead of the prompt's; '' for the prompt's own
    psa: bool
    adaptation: float  # PSA: 0 keeps the look (brightness too), 1 takes whatever the surface can show
    seed: int
    ip2p_model: str = ""  # where the InstructPix2Pix weights are; '' for the public checkpoint
    depth_model: str = ""  # the depth adapter's folder where the model manager has it ready ('' : no depth)
    one_step_model: str = ""  # the one-step model's folder where it is ready (the 'one-step' look's weights)
    dark_outside: bool = True  # black projector pixels where the frame misses the object
    output_size: int = 0  # long side of the final projector image; 0: the projector's native frame
    style_images: tuple = ()  # reference images ('path' or 'path:weight') whose style the look takes
    style_prompt_weight: float = 0.0  # share of the prompt's own look mixed into the style images'

    def lgst_backend(self) -> str:
        """The backend that runs: style images need the reference-image backend, whatever is chosen."""
        return ARBITRARY_BACKEND if self.style_images else self.backend

    def problem(self) -> str:
        """Why Generate cannot run with this request ('' when it can). Cheap (the panel asks on every
        redraw): a style image is only checked to be a file here; Generate reads it before any model."""
        if not self.prompt.strip() and not self.mix.strip() and not self.style_images:
            return "Type a prompt"
        problem = first_problem({"psa_adaptation": self.adaptation, "style_seed": self.seed,
                                 "style_prompt_weight": self.style_prompt_weight})
        if problem:
            return problem
        if self.style_images:
            from ...lapig_core.common.style_image import StyleImageError, check_path, parse_style_image_spec

            try:
                for spec in self.style_images:
                    check_path(parse_style_image_spec(spec)[0])
            except StyleImageError as exc:
                return str(exc)
        if self.output_size < 0:
            return f"The output size must not be negative (0: native), got {self.output_size}"
        return ""

    def backend_options(self) -> dict:
        """Options for the LGST backend (and its availability check): where its model is."""
        if self.style_images:
            return {"style_images": tuple(self.style_images), "prompt_weight": self.style_prompt_weight}
        if self.backend == ONE_STEP_BACKEND:
            return {"model": self.one_step_model} if self.one_step_model else {}
        if self.backend != IP2P_BACKEND:
            return {}
        options = {"model": self.ip2p_model} if self.ip2p_model else {}
        if self.depth_model:  # the drawing follows the object's depth (issue 53)
            options["depth_adapter"] = self.depth_model
        return options


@dataclass(frozen=True)
class ExportSettings:
    """How the projector image is exported: the Preview and Export panel's settings, or the command line's."""
    path: str  # the PNG to write (a JSON sidecar goes beside it)
    bit_depth: int  # 8 or 16
    crossfade_frames: int

    def problem(self) -> str:
        """Why the export cannot run with these settings ('' when it can)."""
        return first_problem({"crossfade_frames": self.crossfade_frames})
