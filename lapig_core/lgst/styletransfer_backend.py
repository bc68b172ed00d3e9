"""The default, offline LGST backend: prompt -> medium + palette + texture + mood -> differentiable look.

The prompt plan (prompt_plan.py) picks the medium: a mix of the 26 Dumoulin styles, or one look of the
library (looks/: woodblock, halftone, neon, ...); then the named colours (a gradient map), a texture
and a mood grade follow in a chain. theta is the mixed conditional-instance-norm scale/shift of every
layer of the style net (990 numbers) when a style is the medium, plus every look stage's parameters
(colours, thresholds, grades). Those few numbers steer colour, texture and stroke of the whole image, so
gradient descent on them (PSA) changes the look smoothly while the conv weights stay fixed.
"""
from __future__ import annotations

import importlib.util

import torch
import torch.nn.functional as F

from .base import LGSTUnavailable, ThetaBackend
from .effects import effects_for_prompt


def internal_shape(h: int, w: int, internal_size: int) -> tuple[int, int]:
    """(h, w) scaled so the longer side is about internal_size, each a multiple of 4 (the net needs it)."""
    scale = internal_size / max(h, w)
    return max(4, int(round(h * scale / 4)) * 4), max(4, int(round(w * scale / 4)) * 4)


def resize(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """Bilinear when enlarging, area average when shrinking (no aliasing); both differentiable."""
    if tuple(x.shape[-2:]) == tuple(size):
        return x
    if size[0] >= x.shape[-2] and size[1] >= x.shape[-1]:
        return F.interpolate(x, size=size, mode="bilinear", align_corners=False)
    return F.interpolate(x, size=size, mode="area")


def look_record(plan) -> dict:
    """What rebuilds a world look without the prompt model (result.json's lgst.look_record): the composition by
    its materials' names, the colours each layer takes, the texture and the mood."""
    entry = getattr(plan, "entry", None)
    return {"world": plan.world.to_dict(), "texture": plan.texture or (entry.texture if entry is not None else None),
            "mood": plan.mood or (entry.mood if entry is not None else None),
            "colour_layers": {str(k): [list(map(float, c)) for c in v]
                              for k, v in (plan.world_colour_layers or {}).items()}}


class StyleTransferBackend(ThetaBackend):
    """Offline backend: MiniLM picks a style mix for the prompt, the torch style net renders it."""

    name = "styletransfer"

    def __init__(self, internal_size: int = 512, blend: float = 0.15, top_k: int = 3,
                 temperature: float | None = None, jitter: float = 0.0, effects: str | list = "auto",
                 looks: bool = True, geometry=None, look_parameters: dict | None = None):
        """internal_size: the style net's working resolution (its styles were trained near 512 px).
        blend: share of the input surface mixed back in, so the content stays recognisable.
        jitter: std of seeded noise added to theta at prepare (0 = the mix exactly; >0 for PSA restarts).
        effects: 'auto' (from the prompt's words), a list of effect objects, or None.
        looks: False maps prompts to the 26 styles only (no looks, colours or moods), as before.
        geometry: the object as the projector sees it (world.geometry.LookGeometry, at any size): the looks of the
        world follow it (crevices, tops, downhill, metres); None: the image alone, as before.
        look_parameters: a world look's sliders as result.json keeps them (look_parameters.LookParameters' dict;
        keys it lacks: the plan's); ValueError with one line for a bad one. Other looks have none.
        """
        if not 0.0 <= blend <= 1.0:
            raise ValueError(f"blend must be in [0, 1], got {blend}")
        self.internal_size, self.blend, self.top_k = int(internal_size), float(blend), int(top_k)
        self.temperature, self.jitter, self.effects_spec = temperature, float(jitter), effects
        self.looks = bool(looks)
        self.geometry = geometry
        self.look_parameters = dict(look_parameters or {})
        self._theta: list[torch.Tensor] = []
        self._anchor: list[torch.Tensor] = []
        self._stages: list = []
        self._layers: list = []
        self._info: dict = {}

    @classmethod
    def availability(cls, **options) -> tuple[bool, str]:
        from .style_net import model_path

        try:
            path = model_path()
        except LGSTUnavailable as exc:
            return False, str(exc)
        if importlib.util.find_spec("onnx") is None:
            return False, "needs the 'onnx' package to read the style network (pip install onnx)"
        from .prompt_mapping import prompt_model_status

        ok, why = prompt_model_status()
        if not ok:
            return True, f"style net found at {path}; prompts need the text model ({why}); explicit mixes work"
        return True, f"offline: 26 styles from {path.name} and the look library, prompts mapped with {why}"

    # -- setup -----------------------------------------------------------------------------------
    def prepare(self, surface, prompt, seed=0, mix=None):
        from . import prompt_mapping as pm
        from .prompt_plan import PromptPlan, plan_prompt

        if surface.ndim != 4 or surface.shape[:2] != (1, 3):
            raise ValueError(f"surface must be (1,3,H,W), got {tuple(surface.shape)}")
        text, notes = pm.validate_prompt(prompt) if (mix is None or prompt) else ("", [])
        if self.effects_spec == "auto":  # kept apart until the prompt is accepted: a refusal changes nothing
            effects = effects_for_prompt(text)
        else:
            effects = list(self.effects_spec or [])
        hints = [e.style_hint for e in effects if getattr(e, "style_hint", "")]
        if mix is not None:
            # an explicit style mix is the medium; a prompt beside it still gives colours and mood
            plan = plan_prompt(text) if text else PromptPlan(prompt="", embedder="")
            plan.medium_kind, plan.look, plan.styles = "style", None, pm.resolve_mix(mix)
            plan.medium_score, plan.runners_up = 1.0, []
            notes.append("style mix given explicitly")
        else:
            if hints:
                notes.append(f"style chosen for the effects' look too: '{', '.join(hints)}'")
            query = ", ".join([text] + hints)
            if self.looks:
                plan = plan_prompt(query, k=self.top_k, temperature=self.temperature)
                if not effects:  # nothing understood: one line, never a tint (an effect is understood)
                    from .not_understood import refuse_if_not_understood
                    from .text_embedder import active

                    refuse_if_not_understood(plan, active().weak)
                notes += plan.notes + plan.unmatched  # so the artist can rephrase
            else:  # the 26 styles only, as before the look library (for comparisons)
                from .text_embedder import active

                info = pm.explain_prompt(query, k=self.top_k, temperature=self.temperature)
                plan = PromptPlan(prompt=text, embedder=active().description, medium_kind="style",
                                  styles=info["mix"], medium_score=info["best_score"])
                notes += info["notes"]
        if plan.medium_kind == "look" and any(e.name == plan.look for e in effects):
            # the named look makes the pixels itself (art lexicon): no second, misaligned grid over it
            effects = [e for e in effects if e.name != plan.look]
            notes = [n for n in notes if not n.startswith("style chosen for the effects' look")]
        self._hold(plan, effects, surface, seed)  # the prompt is accepted: from here on the backend holds its look
        chosen = plan.styles if plan.medium_kind == "style" else []
        self._info = {"backend": self.name, "prompt": text, "seed": int(seed),
                      "styles": [(n, round(float(w), 4)) for n, w in chosen],
                      "looks": [st.label() for st in self._stages],
                      "effects": [e.label() for e in self._effects],
                      "understood": plan.understood(), "understood_line": plan.summary(),
                      "internal_size": self.internal_size, "blend": self.blend,
                      "theta_numel": sum(t.numel() for t in self._theta), "notes": notes}
        controls = self.world_controls()
        if controls is not None:  # the sliders, and what rebuilds the look without the prompt model
            self._info["look_parameters"] = controls.look.to_dict()
            self._info["look_record"] = look_record(plan)
        if self.geometry is not None and plan.medium_kind == "world":  # what shaped the look, and from what
            self._info["geometry"] = self.geometry.to_dict()
            if self.geometry.note:
                notes.append(self.geometry.note)

    def _hold(self, plan, effects, surface, seed):
        """Take the plan's look for `surface`: the style net's tensors (a style medium) and the stages', as theta."""
        self._effects = effects
        self.plan = plan
        self.surface = surface.detach().float().clamp(0, 1)
        self.size = tuple(self.surface.shape[-2:])
        self._layers, self._theta, self._anchor, self._scales = [], [], [], []
        gen = torch.Generator().manual_seed(int(seed))
        if plan.medium_kind == "style":
            self._prepare_style_net(plan.styles, gen)
        self._stages = self._build_stages(plan, seed, self.geometry, self.look_parameters)
        for stage in self._stages:
            for key, value, scale in stage.tensors():
                self._add_theta(value.to(self.surface.device), gen, scale)
                stage.params[key] = self._theta[-1]

    def _add_theta(self, t, gen, scale):
        t = t.detach().clone().float()
        self._anchor.append(t.clone())  # the prompt's choice, before any jitter
        if self.jitter > 0:
            noise = torch.randn(t.shape, generator=gen).to(t.device)
            t = t + self.jitter * (scale if scale else t.abs().mean()) * noise
        self._theta.append(t.requires_grad_(True))
        self._scales.append(scale)

    def _prepare_style_net(self, styles, gen):
        from . import prompt_mapping as pm
        from .style_net import load_style_net

        self.net = load_style_net(self.surface.device)
        # the content input of the net is fixed during PSA: resize it and run its first conv once
        with torch.no_grad():
            self._stem = self.net.stem(resize(self.surface, internal_shape(*self.size, self.internal_size)))
        params = self.net.style_params(pm.mix_vector(styles))
        self._layers = list(params)
        for name in self._layers:
            for t in params[name]:
                self._add_theta(t, gen, None)  # CIN tensors: relative distance (None)

    def world_controls(self):
        """The world stage's sliders and clock (world/stage.WorldControls), or None for a look of another kind."""
        return next((st.world for st in self._stages if hasattr(st, "world")), None)

    def prepare_from_record(self, surface, record: dict, prompt: str = "", seed: int = 0):
        """prepare() for a world look from its result's record (look_record), without the prompt model: the
        composition, its colours, texture and mood as the plan chose them; the sliders from look_parameters."""
        from .prompt_plan import PromptPlan
        from .world.compose import Composition

        if surface.ndim != 4 or surface.shape[:2] != (1, 3):
            raise ValueError(f"surface must be (1,3,H,W), got {tuple(surface.shape)}")
        plan = PromptPlan(prompt=prompt, embedder="", medium_kind="world",
                          world=Composition.from_dict(record["world"]),
                          world_colour_layers={int(k): [tuple(c) for c in v]
                                               for k, v in (record.get("colour_layers") or {}).items()},
                          texture=record.get("texture"), mood=record.get("mood"))
        effects = effects_for_prompt(prompt) if self.effects_spec == "auto" else list(self.effects_spec or [])
        self._hold(plan, effects, surface, seed)
        self._info = {"backend": self.name, "prompt": prompt, "seed": int(seed), "styles": [],
                      "looks": [st.label() for st in self._stages], "effects": [e.label() for e in self._effects],
                      "look_parameters": self.world_controls().look.to_dict(), "look_record": dict(record),
                      "theta_numel": sum(t.numel() for t in self._theta), "notes": []}

    @staticmethod
    def _build_stages(plan, seed: int = 0, geometry=None, look_parameters: dict | None = None) -> list:
        """The look chain after the medium: the look medium, the named colours, the texture, the mood."""
        from .looks import BY_NAME, palette_stage

        rgb = [c.rgb for c in plan.colours] or None
        strength = 0.85
        entry = getattr(plan, "entry", None)
        if entry is not None and not plan.colours:
            # a named entry: its palette, at its strength (0: the medium keeps its own colours); with a
            # craft named beside it as the medium, the entry's colours at least at the default strength
            strength = entry.palette_strength
            if plan.entry_medium_from and strength == 0:
                strength = 0.7
            rgb = [c.rgb for c in plan.entry_colours] if strength > 0 else None
        stages = []
        if plan.medium_kind == "world":  # the world composition makes its own colours (the named ones recolour it)
            from ..look_parameters import LookParameters
            from .world.stage import world_stage

            look = LookParameters.from_dict(look_parameters, LookParameters.from_plan(plan.world, seed))
            stages.append(world_stage(plan.world, plan.world_colour_layers or None, seed=seed, geometry=geometry,
                                      look=look))
            rgb = None
        medium = BY_NAME.get(plan.look) if plan.medium_kind == "look" else None
        if medium is not None:
            stage = medium.make(rgb)
            if entry is not None and not plan.entry_medium_from:
                for key, value in entry.params:  # the name's own start values (its light, its grid)
                    stage.params[key] = torch.as_tensor(value, dtype=torch.float32).reshape(stage.params[key].shape)
            stages.append(stage)
        if rgb and not (medium is not None and medium.uses_colours):
            stages.append(palette_stage(rgb, strength))
        texture = plan.texture or (entry.texture if entry is not None else None)
        mood = plan.mood or (entry.mood if entry is not None else None)
        if texture:
            stages.append(BY_NAME[texture].make(None))
        if mood in ("night", "dark_moody") and plan.medium_kind == "world" and plan.world.base.family == "fire":
            mood = None  # a fire at night is its own light: the night is around it, not over it
        if mood:
            stages.append(BY_NAME[mood].make(None))
        if not stages and plan.medium_kind is None:
            stages.append(BY_NAME["neutral_grade"].make(None))  # nothing understood: a grade PSA can move
        return stages

    def _params(self) -> dict:
        it = iter(self._theta)
        return {name: (next(it), next(it)) for name in self._layers}

    def theta_distance(self):
        """Mean squared change of theta from the prompt's choice: relative for the style net's CIN
        tensors (as before), against each look parameter's typical size for the looks."""
        self._require_prepared()
        terms = []
        for t, a, scale in zip(self._theta, self._anchor, self._scales):
            if scale is None:
                terms.append(((t - a) ** 2).mean() / (a.pow(2).mean() + 1e-6))
            else:
                terms.append(((t - a) ** 2).mean() / (scale * scale))
        return torch.stack(terms).mean()

    # -- rendering -------------------------------------------------------------------------------
    def forward(self):
        self._require_prepared()
        return self._look(getattr(self, "_stem", None), self.surface)

    def _look(self, stem, surface):
        """The medium (styled content blended with the surface, or the surface for a look), then the
        look stages and the effects."""
        if self._layers:
            styled = resize(self.net.forward_from_stem(stem, self._params()), tuple(surface.shape[-2:]))
            out = (1.0 - self.blend) * styled + self.blend * surface
        else:
            out = surface
        for stage in self._stages:
            out = stage(out, surface)
        for effect in self._effects:
            out = effect(out)
        return out

    def render_at(self, surface):
        """The same style strokes (the net runs at its internal size, as in PSA), blended with the
        finer surface, so the look keeps the surface's own detail at any output size."""
        self._require_prepared()
        surface = surface.detach().float().clamp(0, 1).to(self.surface.device)
        with torch.no_grad():
            stem = None
            if self._layers:
                stem = self.net.stem(resize(surface, internal_shape(*surface.shape[-2:], self.internal_size)))
            return self._look(stem, surface).clamp(0, 1)

    def _require_prepared(self):
        if not self._info:
            raise RuntimeError("call prepare(surface, prompt) first")
