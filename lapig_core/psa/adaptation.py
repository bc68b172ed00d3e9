"""Projection surface adaptation (PSA): make the stylization compensable by gradient descent on theta.

    I   = f_theta(s, T)            the backend's stylized target (differentiable in theta)
    I*  = pi_dagger(I, s)           compensation (CompenNeSt), pre-clamp output kept for L_cs
    I^  = pi_hat(I*, s)             simulated capture (PCNet), clamped to [I-, I+]
    L   = w_pc L_pc + w_cs L_cs + w_ps L_ps + w_style L_style

L_style keeps the look the prompt asked for: the three PSA losses alone are minimised by a bland
target (NOTES section 1), so PSA pays for every step away from the un-adapted stylization I0. What it
pays for is set by `adaptation` (the artist's "Adaptation", 0 = keep my look, 1 = whatever this
surface can show):

    L_style = w(a) [ max(0, 1 - 2a) (1 - SSIM(I, I0)) + min(1, 2a) (1 - R(I, I0)) + theta distance ]

R is the structure retention (common/metrics.structure_retention_torch): strokes, edges and colour
relations at any brightness, so from a = 0.5 on a darker or tinted look is not paid as lost style,
only a look whose pattern is gone. w(a) falls from 1.75 to 0.25 (never 0: the bland-target trap).

Every backend's look passes through a ToneField (psa/tone_field.py, a smooth per-channel gain and
offset field guided by the surface's range), optimised together with theta: the fast path for the
large tonal moves a dark or saturated surface needs.

Before the joint steps, a warm start moves the field alone (`warm_start_steps`) on the frozen look,
against a proxy of the PSA loss that needs no network (the per-pixel classical model's L_pc, L_cs
and L_ps, `proxy_psa_loss`) plus the same style term.
Each step costs milliseconds, so the large tonal move a near-black surface needs (the look dark
where the surface is dark, the strokes kept) is made before the first network backward; the joint
steps then refine it with the real losses.

Adam on theta and the field (its normalised steps are the paper's Algorithm 1's; the field has its own
step, `field_lr`) with the paper's schedule (lr / 5 every 50 iterations); stops when the total loss
falls to `stop_ratio` x the first PSA loss (L_pc + L_cs + L_ps, weighted), or at `max_iterations`,
and returns the iterate with the lowest total loss. The style term is weighted relative to the first
PSA loss, so the same weight means the same trade-off on every surface and prompt. The public code's
procedure (re-sample the backend with new seeds until the loss halves), the baseline the benchmarks
measure this against, is research code: tools/research/psa_resample.py.
"""
from __future__ import annotations

import time
from types import SimpleNamespace
from dataclasses import asdict, dataclass, field

import torch

from ..common.adam import Adam
from ..common.metrics import structure_retention_torch
from ..photometric import losses
from ..photometric.surface_models import SurfaceModels
from .tone_field import AdaptedLook

LOSS_TERMS = ("pc", "cs", "ps")


@dataclass
class PSASettings:
    terms: tuple = LOSS_TERMS
    weights: dict = field(default_factory=lambda: {"pc": 1.0, "cs": 1.0, "ps": 1.0})
    style_weight: float = 2.0  # scales w(adaptation) (module docstring), relative to the first PSA loss
    adaptation: float = 0.5  # 0: keep my look (brightness too), 1: whatever this surface can show
    lr: float = 0.01
    field_lr: float = 0.03  # Adam step of the tone field's parameters in the joint steps (after the warm start)
    tone_field: bool = True  # the look passes through a ToneField that PSA optimises
    keep_light_weight: float = 1.0  # the light the surface can show is not given up (keep_light_loss)
    warm_start_steps: int = 80  # field-only steps on the frozen look before the joint ones (0: none)
    warm_start_lr: float = 0.15
    lr_step: int = 50
    lr_gamma: float = 0.2
    stop_ratio: float | None = None  # None: from adaptation (stop_ratio_for)
    max_iterations: int = 20  # joint steps after the warm start (about 0.6 s each at 256x192 on 2 cores)
    seed: int = 0

    def __post_init__(self):
        if not 0.0 <= self.adaptation <= 1.0:
            raise ValueError(f"adaptation must be between 0 and 1, got {self.adaptation}")
        if self.stop_ratio is None:
            self.stop_ratio = stop_ratio_for(self.adaptation)

    def style_mix(self) -> tuple[float, float, float]:
        """(weight of 1 - SSIM, weight of 1 - structure retention, w(a)) for this adaptation."""
        a = self.adaptation
        return max(0.0, 1.0 - 2.0 * a), min(1.0, 2.0 * a), self.style_weight * (0.25 + 1.5 * (1.0 - a))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["terms"] = list(self.terms)
        return d


def stop_ratio_for(adaptation: float) -> float:
    """How far the total loss must fall before PSA stops: 0.7 x the first PSA loss when the look is
    kept, 0.1 x when the surface decides (0.4 at the default 0.5)."""
    return round(0.7 - 0.6 * adaptation, 4)


@dataclass
class PSAResult:
    target: torch.Tensor  # I of the best iterate (1,3,H,W)
    projector_image: torch.Tensor  # its compensation I*
    simulated: torch.Tensor  # pi_hat(I*)
    initial_target: torch.Tensor  # I0, the un-adapted stylization
    iterations: int
    seconds: float
    history: list
    best_iteration: int
    stopped: str  # "threshold", "max_iterations", "cancelled"
    state: dict = None  # the backend's best theta (and the tone field's, under "tone_field")
    look: object = None  # what renders `state` (the AdaptedLook with a tone field, else the backend)
    warm_start_steps: int = 0  # field-only steps before the joint ones
    first_psa_loss: float | None = None  # the un-adapted look's PSA loss (the stop rule's reference)


def _mean_on_object(per_pixel: torch.Tensor, models: SurfaceModels) -> torch.Tensor:
    """The mean of a (1,C,H,W) per-pixel loss over the object's pixels (all without a mask)."""
    if models.on_object is None:
        return per_pixel.mean()
    m = models.on_object.to(per_pixel.dtype)
    return (per_pixel * m).sum() / (m.sum().clamp_min(1.0) * per_pixel.shape[1])


def psa_losses(target, models: SurfaceModels) -> dict:
    """All three PSA losses of a target (tensors, differentiable, on the object's pixels), plus I*
    and I^. Without a mask they are the paper's means over the frame."""
    comp, raw = models.compensate(target, return_raw=True)
    sim = models.simulate(comp)
    return {"pc": _mean_on_object((sim - target) ** 2, models),
            "cs": _mean_on_object(losses.compensation_saturation_map(raw), models),
            "ps": _mean_on_object(losses.physical_saturation_map(target, models.i_min, models.i_max), models),
            "comp": comp, "sim": sim}


def loss_maps(target, models: SurfaceModels) -> dict:
    """Per-pixel L_cs and L_ps (H, W) on the CPU: where the surface cannot show this target (computed where
    the models are)."""
    with torch.no_grad():
        target = target.to(models.device)
        _, raw = models.compensate(target, return_raw=True)
        return {"cs": losses.compensation_saturation_map(raw)[0, 0].cpu(),
                "ps": losses.physical_saturation_map(target, models.i_min, models.i_max)[0, 0].cpu()}


def psa_loss(parts, settings) -> torch.Tensor:
    """The weighted sum of the settings' PSA terms of `parts` (psa_losses)."""
    return sum(settings.weights.get(t, 1.0) * parts[t] for t in settings.terms)


def _style_loss(target, anchor, backend, settings) -> torch.Tensor:
    """L_style / w(a): what PSA pays for moving away from the un-adapted look (module docstring)."""
    w_ssim, w_structure, _ = settings.style_mix()
    value = torch.zeros((), dtype=target.dtype, device=target.device)
    if w_ssim > 0:
        value = value + w_ssim * losses.ssim_loss(target, anchor)
    if w_structure > 0:
        value = value + w_structure * (1.0 - structure_retention_torch(target, anchor))
    distance = getattr(backend, "theta_distance", None)
    return value + (distance() if distance is not None else 0.0)


def keep_light_loss(target, anchor, models: SurfaceModels) -> torch.Tensor:
    """What the look lost below the light the surface can show: the mean squared shortfall of the
    target under clamp(I0, I-, I+), as a share of that light's energy. The structure term is blind to brightness, so without this a look
    darkened to black (which every PSA loss likes) would count as the same style; with it, PSA
    darkens only where the surface cannot reach the look."""
    reachable = torch.minimum(torch.maximum(anchor, models.i_min), models.i_max)
    # as a share of the reachable light's energy, so it weighs like the style term on any surface
    return (torch.relu(reachable - target) ** 2).mean() / (reachable ** 2).mean().clamp_min(1e-8)


def adapted_look(backend, models: SurfaceModels) -> AdaptedLook:
    """The backend with a ToneField for this surface after it (identity until PSA moves it)."""
    return backend if isinstance(backend, AdaptedLook) else AdaptedLook(backend, models.i_min, models.i_max)


def _optimiser(look, settings):
    if isinstance(look, AdaptedLook):
        groups = [{"params": look.backend_parameters(), "lr": settings.lr},
                  {"params": look.field_parameters(), "lr": settings.field_lr}]
    else:
        groups = [{"params": look.parameters(), "lr": settings.lr}]
    return Adam(groups)


def proxy_psa_loss(target, models: SurfaceModels, settings: PSASettings) -> torch.Tensor:
    """The PSA loss as the per-pixel classical model sees it, with no network: the compensation is
    (I - I-) / (I+ - I-), so L_cs is its distance outside [0, 1], and the capture is
    clamp(I, I-, I+), so L_pc = L_ps. Close to the learned losses (L_cs dominates both on a dark
    surface), and milliseconds to evaluate."""
    ps = _mean_on_object(losses.physical_saturation_map(target, models.i_min, models.i_max), models)
    span = (models.i_max - models.i_min).clamp_min(0.01)
    cs = _mean_on_object(losses.compensation_saturation_map((target - models.i_min) / span), models)
    parts = {"pc": ps, "ps": ps, "cs": cs}
    return psa_loss(parts, settings)


WARM_START_MIN_SIDE = 96  # the warm start runs at half the working frame while its short side stays at least this


def _at_warm_start_scale(look, models: SurfaceModels):
    """The frozen look and the surface at half the frame for the warm start: the field is smooth (a
    6x6 grid and the surface's range), so half the pixels steer it as well, at a quarter of the cost.
    Only the tensors the proxy reads are resized (no network runs at that scale)."""
    if min(look.shape[-2:]) < 2 * WARM_START_MIN_SIDE:
        return look, models
    half = lambda t: None if t is None else torch.nn.functional.avg_pool2d(t, 2)  # noqa: E731
    small = SimpleNamespace(i_min=half(models.i_min), i_max=half(models.i_max),
                            on_object=None if models.on_object is None else (half(models.on_object) > 0.5).float())
    return half(look), small


def warm_start_field(look: AdaptedLook, anchor, models: SurfaceModels, settings: PSASettings,
                     cancel_event=None) -> int:
    """Field-only steps on the frozen look (module docstring); returns how many ran. Keeps the
    field's best proxy iterate, so it can only lower the proxy from the identity."""
    if settings.warm_start_steps <= 0:
        return 0
    _, _, style_weight = settings.style_mix()
    params = look.field_parameters()
    opt = Adam(params, lr=settings.warm_start_lr)
    base, models = _at_warm_start_scale(anchor.detach(), models)
    with torch.no_grad():  # the proxy's own first value scales the style term, as `first` does later
        scale = max(float(proxy_psa_loss(base, models, settings)), 1e-8)
    best, steps = None, 0
    for step in range(settings.warm_start_steps + 1):
        if cancel_event is not None and cancel_event.is_set():
            break
        adapted = look.field.apply(base, models.i_min, models.i_max)
        proxy = proxy_psa_loss(adapted, models, settings)
        total = proxy + style_weight * scale * (_style_loss(adapted, base, look, settings)
                                                + settings.keep_light_weight * keep_light_loss(adapted, base, models))
        value = float(total.detach())
        if best is None or value < best[0]:
            best = (value, [p.detach().clone() for p in params])
        if step == settings.warm_start_steps:
            break
        # the step falls linearly to a tenth, so the field settles instead of circling the minimum
        opt.param_groups[0]["lr"] = settings.warm_start_lr * (1.0 - 0.9 * step / settings.warm_start_steps)
        opt.zero_grad(set_to_none=True)
        total.backward()
        opt.step()
        steps += 1
    if best is None:  # cancelled before the first step: the field stays the identity
        return 0
    with torch.no_grad():
        for p, v in zip(params, best[1]):
            p.copy_(v)
    return steps


def check_terms(settings: PSASettings) -> None:
    """ValueError unless the settings' terms are a non-empty subset of LOSS_TERMS."""
    unknown = set(settings.terms) - set(LOSS_TERMS)
    if unknown or not settings.terms:
        raise ValueError(f"PSA terms must be a non-empty subset of {LOSS_TERMS}, got {settings.terms}")


def run_psa(backend, models: SurfaceModels, settings: PSASettings | None = None, on_progress=None,
            cancel_event=None) -> PSAResult:
    """Adapt a prepared backend (backend.prepare(surface, prompt) already called) to the surface."""
    settings = settings or PSASettings()
    check_terms(settings)
    torch.manual_seed(settings.seed)
    t0 = time.perf_counter()
    backend = adapted_look(backend, models) if settings.tone_field else backend
    _, _, style_weight = settings.style_mix()
    with torch.no_grad():
        anchor = backend.forward().detach()
        # the first PSA loss is the un-adapted look's, so the stop rule and the style scale do not
        # move with the warm start
        first = float(psa_loss(psa_losses(anchor, models), settings))
    warm_steps = 0
    if isinstance(backend, AdaptedLook):
        warm_steps = warm_start_field(backend, anchor, models, settings, cancel_event)
    opt = _optimiser(backend, settings)
    base_lrs = [group["lr"] for group in opt.param_groups]
    history, best, stopped = [], None, "max_iterations"
    for it in range(settings.max_iterations + 1):
        # the first iterate is always evaluated, so a cancelled run still returns a result
        if it > 0 and cancel_event is not None and cancel_event.is_set():
            stopped = "cancelled"
            break
        target = backend.forward()
        parts = psa_losses(target, models)
        psa = psa_loss(parts, settings)
        psa_value = float(psa.detach())
        style = _style_loss(target, anchor, backend, settings)
        # the style term is scaled by the first PSA loss, so one weight fits every prompt and surface
        style = style + settings.keep_light_weight * keep_light_loss(target, anchor, models)
        total = psa + style_weight * max(first, 1e-8) * style
        if not torch.isfinite(total):
            stopped = "non-finite loss"
            break
        entry = {"iteration": it, "psa_loss": psa_value, "style_loss": float(style.detach()),
                 "total": float(total.detach()), **{k: float(parts[k].detach()) for k in LOSS_TERMS}}
        history.append(entry)
        if best is None or entry["total"] < best[0]["total"]:
            best = (entry, backend.state(), target.detach(), parts["comp"].detach(), parts["sim"].detach())
        if on_progress:
            on_progress(min(it / settings.max_iterations, 1.0),
                        f"PSA iteration {it}: loss {entry['psa_loss']:.5f} (first {first:.5f})")
        # the paper's rule on the total loss: style drift counts against reaching the threshold
        if entry["total"] <= settings.stop_ratio * first and (it > 0 or warm_steps):
            stopped = "threshold"
            break
        if it == settings.max_iterations:
            break
        for group, base_lr in zip(opt.param_groups, base_lrs):  # the step falls by lr_gamma every lr_step
            group["lr"] = base_lr * settings.lr_gamma ** (it // settings.lr_step)
        opt.zero_grad(set_to_none=True)
        total.backward()
        opt.step()
    entry, state, target, comp, sim = best
    backend.load_state(state)
    return PSAResult(target, comp, sim, anchor, iterations=len(history) - 1, seconds=time.perf_counter() - t0,
                     history=history, best_iteration=entry["iteration"], stopped=stopped, state=state,
                     look=backend, warm_start_steps=warm_steps, first_psa_loss=first)


def without_psa(backend, models: SurfaceModels) -> PSAResult:
    """The un-adapted stylization and its compensation, in the same shape as a PSA result."""
    t0 = time.perf_counter()
    with torch.no_grad():
        target = backend.forward()
        parts = psa_losses(target, models)
    entry = {"iteration": 0, "psa_loss": float(sum(parts[t] for t in LOSS_TERMS)),
             **{t: float(parts[t]) for t in LOSS_TERMS}}
    return PSAResult(target, parts["comp"], parts["sim"], target, 0, time.perf_counter() - t0, [entry], 0,
                     "not run", backend.state(), look=backend)
