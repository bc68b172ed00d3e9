"""The projector-image pipeline on one captured setup, bpy-free.

captured setup -> fine-tuned CompenNeSt + PCNet (cached next to the captures)
              -> LGST target from the white-lit surface I+ and the prompt
              -> with and without PSA: target, projector image, simulated capture,
                 the projector image black where the frame misses the object (by default).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch

from .photometric import checkpoints, choice as compensator_choice
from .common import compute_device, metrics
from .common.phases import PhaseTimes
from .capture.dataset import CaptureSet, setup_dir_of
from .photometric.classical import ClassicalModel
from .photometric.classical_compensator import ClassicalCompensator, ClassicalSimulator
from .photometric.first_look import load_first_look
from .photometric.finetune import device_recipe, finetune, load_setup_model, save_setup_model
from .lgst import DEFAULT_BACKEND, LGSTBackend, backend_class, prepared_backend
from .native_output import NativeResult, native_output
from .photometric.surface_models import SurfaceModels
from .psa.adaptation import PSAResult, PSASettings, run_psa, without_psa
from .psa.reach import surface_truth
from .photometric.training_data import SurfaceTensors


def train_models(cs: CaptureSet, on_progress=None, cancel_event=None, save=True,
                 iterations: int | None = None, device=None, recipe_of=None) -> dict:
    """Fine-tune CompenNeSt and PCNet on all the captured training pairs, from the pretrained weights.

    iterations: per network (default: the recipe's); fewer give a rough, quick fine-tune. On a GPU the
    compensation trains on whole images (finetune.device_recipe).
    device: where they train (None: the CPU); the networks are returned there, and out["device"] says which.
    recipe_of: the device whose recipe is followed (None: `device`'s). A parity check gives the CPU, so that a GPU
    runs the very recipe the CPU's figures were made with.
    """
    recipe_of = device if recipe_of is None else recipe_of
    out, trained, t0 = {}, {}, time.perf_counter()
    phases = PhaseTimes()
    # first: the compensation's camera-space loss measures its error through the classical model (the capture's
    # first look is that same fit, on the same pairs: reused where the capture has one)
    with phases.timing("first_look_load"):
        look = load_first_look(setup_dir_of(cs), cs.meta.get("fingerprint"))
    with phases.timing("classical_fit"):
        classical = look.classical if look is not None else ClassicalModel.fit(cs.prj_train, cs.cam_train)
    for i, (arch, role) in enumerate((("CompenNeSt", "compensation"), ("PCNet", "simulation"))):
        def progress(p, msg, i=i, arch=arch):
            if on_progress:
                on_progress((i + p) / 2, f"{arch}: {msg}")

        t = time.perf_counter()
        model, result = finetune(cs, arch, role, recipe=device_recipe(arch, role, iterations, recipe_of),
                                 on_progress=progress,
                                 cancel_event=cancel_event, classical=classical, device=device)
        if result.cancelled:
            raise InterruptedError("training cancelled")
        # the iterations alone, and the rest of the fine-tune (the pairs, the pretrained weights, validation)
        phases.add(f"{arch}_steps", result.seconds)
        phases.add(f"{arch}_setup", time.perf_counter() - t - result.seconds)
        out[arch], trained[arch] = model, (role, result)
    with phases.timing("save"):
        if save:  # both at once: a cancel while PCNet trains leaves the folder as it was
            for arch, (role, result) in trained.items():
                save_setup_model(setup_dir_of(cs), out[arch], role, cs, iterations=result.iterations,
                                 train_seconds=round(result.seconds, 2), device=compute_device.describe(device))
    # the learned and the classical compensation, validated on the held-back pairs: the better one is used
    with phases.timing("choice"):
        chosen, classical = compensator_choice.fit_and_choose(cs, out["CompenNeSt"], out["PCNet"], classical)
        if save:
            compensator_choice.save_choice(setup_dir_of(cs) / "models", chosen, classical)
    out["choice"], out["classical"] = chosen, classical
    out["seconds"] = time.perf_counter() - t0
    out["steps_seconds"] = {arch: result.seconds for arch, (_, result) in trained.items()}  # the iterations alone
    out["phases"] = phases
    out["threads"] = {arch: result.threads for arch, (_, result) in trained.items() if result.threads}  # the CPU's
    out["device"] = compute_device.describe(device)
    return out



@dataclass
class SavedModels:
    """A capture's fine-tuned networks and its compensator choice, loaded once from its models folder."""
    compensation: object
    simulation: object
    choice: object = None  # None: saved before the choice existed (surface_models measures it)
    classical: object = None


def load_saved_models(folder) -> SavedModels:
    """The capture's saved models, each checkpoint read once; NotTrainedYet when there are none for this
    very capture (its fingerprint), CheckpointError for a file that cannot be used, DatasetError for a
    folder that is not a capture."""
    from .capture.dataset import read_setup_json, resolve_setup

    layout = resolve_setup(folder)
    return _load_saved(setup_dir_of(layout), read_setup_json(layout.setup_json).get("fingerprint"))


def _load_saved(setup_dir, fingerprint) -> SavedModels:
    comp, _ = load_setup_model(setup_dir, "CompenNeSt", "compensation", fingerprint)
    sim, _ = load_setup_model(setup_dir, "PCNet", "simulation", fingerprint)
    saved = compensator_choice.load_choice(Path(setup_dir) / "models")
    return SavedModels(comp, sim, *(saved if saved is not None else (None, None)))


def saved_models_problem(folder) -> tuple[str | None, SavedModels | None]:
    """(problem, models) for the capture at `folder`: (None, the loaded models) when both networks are
    saved for it, so that Generate need not train them on the way and loads them only here; ('', None)
    when they were never trained; (the damage, None) when a saved file cannot be used."""
    from .capture.dataset import DatasetError

    try:
        return None, load_saved_models(folder)
    except DatasetError as exc:
        return str(exc), None
    except checkpoints.NotTrainedYet:
        return "", None
    except checkpoints.CheckpointError as exc:
        return str(exc), None


def chosen_compensator(learned, chosen, classical):
    """The module that compensates this setup: the fine-tuned network, or the classical model where
    it measured better."""
    if chosen is not None and chosen.chosen == compensator_choice.CLASSICAL and classical is not None:
        return ClassicalCompensator(classical)
    return learned


def surface_models(cs: CaptureSet, train_if_missing=True, on_progress=None, cancel_event=None,
                   iterations: int | None = None, notes: list | None = None,
                   saved: SavedModels | None = None, device=None) -> SurfaceModels:
    """The setup's fine-tuned models: `saved` (loaded already), else loaded when saved for this very setup,
    else trained now (with `iterations` as in train_models). A damaged saved model is trained again and
    saved over, and `notes` gets a line that says so. A choice is measured on cs's pairs only for models
    saved before the choice existed. device: where they run (None: the CPU), the training too."""
    try:
        saved = saved or _load_saved(setup_dir_of(cs), cs.meta.get("fingerprint"))
        comp, sim = saved.compensation, saved.simulation
        if saved.choice is None:  # models fine-tuned before the choice existed: measure it now
            chosen, classical = compensator_choice.fit_and_choose(cs, comp, sim)
            compensator_choice.save_choice(setup_dir_of(cs) / "models", chosen, classical)
        else:
            chosen, classical = saved.choice, saved.classical
    except checkpoints.CheckpointError as exc:
        if not train_if_missing:
            raise
        if notes is not None and not isinstance(exc, checkpoints.NotTrainedYet):
            notes.append(f"the saved models could not be used ({exc}): fine-tuned them again and saved over them")
        trained = train_models(cs, on_progress, cancel_event, iterations=iterations, device=device)
        comp, sim = trained["CompenNeSt"], trained["PCNet"]
        chosen, classical = trained["choice"], trained["classical"]
    surf = SurfaceTensors.from_capture_set(cs)
    models = SurfaceModels(chosen_compensator(comp, chosen, classical), sim, surf.s, surf.i_min, surf.i_max,
                           on_object=psa_mask(cs)).to(device)
    models.choice = chosen  # which compensator, and by how much: the panel and result.json show it
    return models


def first_look_models(cs: CaptureSet, classical: ClassicalModel, device=None) -> SurfaceModels:
    """The first look's models (photometric/first_look): the classical model compensates, and its forward
    direction is the simulator PSA runs its losses through; no network is involved. device: where they run
    (None: the CPU)."""
    surf = SurfaceTensors.from_capture_set(cs)
    models = SurfaceModels(ClassicalCompensator(classical), ClassicalSimulator(classical), surf.s, surf.i_min,
                           surf.i_max, on_object=psa_mask(cs)).to(device)
    models.choice = None
    models.first_look = True
    return models


@dataclass
class StylizeResult:
    without: PSAResult
    with_psa: PSAResult | None
    describe: dict
    settings: PSASettings
    dark_outside: bool = False  # the projector images are black off the object
    backend: LGSTBackend | None = None  # prepared: renders a result's theta at other sizes (native output)
    truth: dict | None = None  # what the surface can show of the look (psa/reach.surface_truth)
    device: str = ""  # which device ran it (compute_device.describe)

    def style_retention(self) -> dict:
        """The PSA look against the un-adapted one: structure (style at any brightness, the new
        measure) beside the old SSIM and PSNR."""
        if self.with_psa is None:
            return {}
        a, b = self.with_psa.target, self.without.target
        return {"structure": metrics.structure_retention(a, b), "ssim": metrics.ssim(a, b),
                "psnr": metrics.psnr(a, b)}


# The registration's valid map is the object's footprint only where the Gray code decodes: on a
# near-black surface it decodes on the bright features alone (5% of the frame on `black_dots`,
# where the geometry says 100%). Below this share of the geometric coverage the map is not the
# object, so nothing is darkened outside and PSA's losses use the whole frame.
MIN_VALID_OF_COVERAGE = 0.6


def unreliable_footprint(cs: CaptureSet) -> str | None:
    """Why the registration's valid map cannot stand for the object (None when it can, or when
    the set has no map at all)."""
    if cs.projector_valid is None:
        return None
    valid = float(np.mean(cs.projector_valid))
    covered = float((cs.meta.get("coverage") or {}).get("projector_on_object", valid))
    if valid >= MIN_VALID_OF_COVERAGE * covered and valid > 0.0:
        return None
    return (f"the registration found the object on only {valid:.0%} of the projector frame, where the rig's "
            f"geometry puts it on {covered:.0%} (a very dark surface decodes poorly): the projector image "
            "is not darkened outside the object, and PSA weighs the whole frame")


def object_footprint(cs: CaptureSet):
    """The (H, W) valid map where it stands for the object, else None (the whole frame)."""
    return None if unreliable_footprint(cs) else cs.projector_valid


def psa_mask(cs: CaptureSet) -> torch.Tensor | None:
    """The on-object mask PSA's losses use, or None where the set has no registration (public
    sets) or its valid map is not the object (unreliable_footprint)."""
    footprint = object_footprint(cs)
    return None if footprint is None else on_object_mask(footprint)


def on_object_mask(valid) -> torch.Tensor:
    """(1,1,H,W) float mask of the projector pixels that land on the object (registration's valid map)."""
    return torch.as_tensor(valid, dtype=torch.float32)[None, None]


def on_the_cpu(result: PSAResult | None) -> PSAResult | None:
    """A result with its images and its state on the CPU, for numpy and the files (its look stays where it
    ran: the native output renders it there)."""
    if result is None:
        return None
    return replace(result, target=result.target.cpu(), projector_image=result.projector_image.cpu(),
                   simulated=result.simulated.cpu(), initial_target=result.initial_target.cpu(),
                   state=compute_device.moved(result.state, "cpu"))


def darkened_outside(result: PSAResult, mask: torch.Tensor, models: SurfaceModels) -> PSAResult:
    """The result with its projector image black where ``mask`` is 0 (no stray light behind the
    object), and the simulated capture of that image."""
    projector_image = result.projector_image * mask
    with torch.no_grad():
        simulated = models.simulate(projector_image)
    return replace(result, projector_image=projector_image, simulated=simulated)


def stylize(cs: CaptureSet, models: SurfaceModels, prompt: str, backend: str = DEFAULT_BACKEND, seed: int = 0,
            mix=None, psa: bool = True, settings: PSASettings | None = None, on_progress=None, cancel_event=None,
            backend_options: dict | None = None, dark_outside: bool = True, geometry=None) -> StylizeResult:
    """The prompt's look on this surface, and its PSA-adapted version.

    dark_outside: black projector pixels where the frame misses the object (where the capture set
    knows it: setups captured here; public sets have no registration).
    geometry: what the looks of the world follow: a lgst/world/geometry.LookGeometry (the object as the projector
    sees it), "capture" (no 3D model: the captured surface stands in), or None (the image alone); InstructPix2Pix
    takes its depth where its options name a depth adapter (backend_options["depth_adapter"]).
    It runs where the models are (SurfaceModels.to): the backend follows the surface's device; the
    result's images come back on the CPU."""
    settings = settings or PSASettings(seed=seed)
    device = models.device
    # LGST sees the white-lit surface (as the paper)
    surface = SurfaceTensors.from_capture_set(cs).i_max.to(device)
    backend_options = with_device(backend, backend_options, device)
    if geometry is not None and (backend == DEFAULT_BACKEND or getattr(backend_class(backend), "takes_geometry",
                                                                          False)):
        from .lgst.world.geometry import from_capture

        if isinstance(geometry, str):
            geometry = from_capture(surface[0].permute(1, 2, 0).cpu().numpy())
        backend_options["geometry"] = geometry  # the looks of the world; InstructPix2Pix's depth adapter
    lgst, fallback = prepared_backend(backend, surface, prompt, seed=seed, mix=mix, options=backend_options)
    plain = without_psa(lgst, models)
    adapted = None
    if psa:
        adapted = run_psa(lgst, models, settings, on_progress=on_progress, cancel_event=cancel_event)
    footprint_note = unreliable_footprint(cs) if dark_outside else None
    dark_outside = dark_outside and cs.projector_valid is not None and footprint_note is None
    if dark_outside:
        mask = on_object_mask(cs.projector_valid).to(device)
        plain = darkened_outside(plain, mask, models)
        adapted = darkened_outside(adapted, mask, models) if adapted is not None else None
    describe = lgst.describe()
    if fallback:
        describe["fallback"] = fallback
        describe.setdefault("notes", []).append(fallback)
    if footprint_note:
        describe.setdefault("notes", []).append(footprint_note)
    plain, adapted = on_the_cpu(plain), on_the_cpu(adapted)
    # measured on the CPU, in float64 (which MPS has not)
    truth = surface_truth(plain.target, adapted.target if adapted is not None else None, models.i_min.cpu(),
                          models.i_max.cpu(), object_footprint(cs))  # on the object, where it is known
    # the look that renders the chosen state: with the PSA tone field when PSA ran
    look = adapted.look if adapted is not None and adapted.look is not None else lgst
    return StylizeResult(plain, adapted, describe, settings, dark_outside, look, truth,
                         compute_device.describe(device))


def with_device(backend: str, options: dict | None, device) -> dict:
    """The backend's options with `device` where the backend takes one (InstructPix2Pix picks its own
    otherwise); the others follow the surface's device."""
    options = dict(options or {})
    if getattr(backend_class(backend), "takes_device", False):
        options.setdefault("device", device)
    return options


def output_at(cs: CaptureSet, models: SurfaceModels, res: StylizeResult, width: int, height: int,
              budget_mb: float | None = None) -> NativeResult | None:
    """The chosen look (with PSA when it ran) and its projector image at width x height (e.g. the
    projector's native frame); None when that is the working frame itself."""
    if (width, height) == cs.frame_size:
        return None
    chosen = res.with_psa or res.without
    return native_output(setup_dir_of(cs), models, res.backend, chosen.state, width, height, res.dark_outside,
                         budget_mb)


def as_image(t: torch.Tensor):
    """(1,3,H,W) tensor -> (H,W,3) numpy for writing and rendering."""
    return t.detach()[0].permute(1, 2, 0).clamp(0, 1).cpu().numpy()
