"""The LGST backend interface (I = f_theta(s, T)) and the registry of backends.

A backend turns a surface capture s and a prompt T into the stylized target I, and exposes theta (the
tensors PSA optimises) so that projection-consistency losses can be back-propagated into the look.
"""
from __future__ import annotations

import torch


class LGSTUnavailable(RuntimeError):
    """A backend cannot run here (a package or model file is missing); the message says what to install."""


class LGSTBackend:
    """Interface every LGST backend implements. Call prepare() once, then forward() as often as needed."""

    name: str = "base"
    # True: the constructor takes `device` (the pipeline passes the models'); the others run where the
    # surface given to prepare() is
    takes_device: bool = False

    @classmethod
    def availability(cls, **options) -> tuple[bool, str]:
        """(can it run here, why not / what it uses): cheap, loads no model. options: the constructor's
        (some say where the model is)."""
        return True, ""

    def prepare(self, surface: torch.Tensor, prompt: str, seed: int = 0, mix=None) -> None:
        """surface (1,3,H,W) in [0,1]: choose the style for `prompt` (or the explicit `mix`), set up theta."""
        raise NotImplementedError

    def parameters(self) -> list[torch.Tensor]:
        """theta: the leaf tensors (requires_grad=True) that PSA optimises."""
        raise NotImplementedError

    def forward(self) -> torch.Tensor:
        """The target image (1,3,H,W) in [0,1], differentiable w.r.t. parameters()."""
        raise NotImplementedError

    def render_at(self, surface: torch.Tensor) -> torch.Tensor:
        """The look of the current theta for another view of the surface (1,3,H,W), e.g. the white-lit
        surface registered at the projector's native resolution; no graph. theta does not depend on
        the resolution, so PSA at the working frame carries over. By default the look is rendered
        as forward() does and resized; backends that can use the finer surface override this."""
        with torch.no_grad():
            look = self.forward()
        return torch.nn.functional.interpolate(look, size=tuple(surface.shape[-2:]), mode="bicubic",
                                               align_corners=False).clamp(0, 1)

    def stylize(self, surface: torch.Tensor, prompt: str, seed: int = 0, mix=None) -> torch.Tensor:
        """prepare + forward without building a graph (for previews)."""
        self.prepare(surface, prompt, seed=seed, mix=mix)
        with torch.no_grad():
            return self.forward()

    def describe(self) -> dict:
        """What was chosen: {'backend', 'styles': [(name, weight)], 'effects': [...], ...}."""
        raise NotImplementedError

    def state(self) -> dict:
        """A detached copy of theta, so a PSA run can keep the best one."""
        return {"theta": [p.detach().clone() for p in self.parameters()]}

    def load_state(self, state: dict) -> None:
        """Copy a state() back into theta in place (the optimiser keeps pointing at the same tensors)."""
        theta = state["theta"]
        params = self.parameters()
        if len(theta) != len(params):
            raise ValueError(f"state has {len(theta)} tensors, the backend has {len(params)}")
        with torch.no_grad():
            for p, v in zip(params, theta):
                p.copy_(v)


class ThetaBackend(LGSTBackend):
    """A backend whose theta is a list of leaf tensors kept beside a copy of their prompt-given values.

    Subclasses fill self._theta and self._anchor in prepare(), and self._info (what describe() gives);
    PSA's style-retention term uses theta_distance().
    """

    _theta: list = []
    _anchor: list = []
    _info: dict = {}

    def _require_prepared(self):
        if not self._theta:
            raise RuntimeError("call prepare(surface, prompt) first")

    def parameters(self):
        self._require_prepared()
        return list(self._theta)

    def anchor(self) -> list[torch.Tensor]:
        """theta as the prompt gave it (for a trust region / style-retention term in PSA)."""
        self._require_prepared()
        return [a.clone() for a in self._anchor]

    def theta_distance(self) -> torch.Tensor:
        """Mean squared relative change of theta from the prompt's choice (differentiable)."""
        self._require_prepared()
        terms = [((t - a) ** 2).mean() / (a.pow(2).mean() + 1e-6) for t, a in zip(self._theta, self._anchor)]
        return torch.stack(terms).mean()

    def describe(self):
        self._require_prepared()
        return dict(self._info)

    def state(self):
        """theta, and what was chosen with it (a PSA run keeps its best state with its description)."""
        return {"theta": [p.detach().clone() for p in self.parameters()], "describe": self.describe()}


BACKENDS: dict[str, type] = {}


def register_backend(name: str, cls: type) -> None:
    """Make `cls` (an LGSTBackend subclass) available as get_backend(name)."""
    if not (isinstance(cls, type) and issubclass(cls, LGSTBackend)):
        raise TypeError(f"{cls!r} is not an LGSTBackend subclass")
    BACKENDS[name] = cls


def backend_class(name: str) -> type:
    """The backend registered as `name`; ValueError naming the registered backends if it is unknown
    (cheap: callers check a name before any expensive step)."""
    if name not in BACKENDS:
        known = ", ".join(sorted(BACKENDS)) or "(none registered)"
        raise ValueError(f"unknown LGST backend '{name}'; registered backends: {known}")
    return BACKENDS[name]


def get_backend(name: str, **kwargs) -> LGSTBackend:
    """A new backend instance; ValueError naming the registered backends if `name` is unknown."""
    return backend_class(name)(**kwargs)


def available_backends() -> dict[str, tuple[bool, str]]:
    """{name: (available, reason)} for every registered backend, without loading any model."""
    out = {}
    for name, cls in sorted(BACKENDS.items()):
        try:
            out[name] = cls.availability()
        except Exception as exc:  # a broken check must not hide the other backends
            out[name] = (False, f"availability check failed: {exc}")
    return out
