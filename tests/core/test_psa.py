# SPDX-License-Identifier: GPL-3.0-or-later
"""PSA at 32 px with small random networks: gradients reach theta, the stop rule, best iterate, cancel."""
import threading

import numpy as np

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric.surface_models import SurfaceModels
from lapig.lapig_core.psa import adaptation as psa
from lapig.lapig_core.photometric.checkpoints import new_model
from lapig.lapig_core.lgst.base import LGSTBackend
from lapig.tools.research import psa_resample

SIZE = 32


class TintBackend(LGSTBackend):
    """A minimal differentiable look: the surface times a learnable colour gain plus an offset."""

    name = "tint-test"

    def prepare(self, surface, prompt, seed=0, mix=None):
        g = torch.Generator().manual_seed(seed)
        self.surface = surface
        self.gain = (1.6 + 0.1 * torch.rand(1, 3, 1, 1, generator=g)).requires_grad_(True)
        self.offset = torch.full((1, 3, 1, 1), 0.1).requires_grad_(True)
        self.prompt = prompt

    def parameters(self):
        return [self.gain, self.offset]

    def forward(self):
        return (self.surface * self.gain + self.offset).clamp(0, 1)

    def describe(self):
        return {"backend": self.name, "prompt": self.prompt, "styles": []}


@pytest.fixture
def models():
    torch.manual_seed(0)
    s = torch.rand(1, 3, SIZE, SIZE) * 0.5 + 0.25
    i_min, i_max = s * 0.1, s * 0.9
    return SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), s, i_min, i_max)


def _backend(models, seed=0):
    b = TintBackend()
    b.prepare(models.s, "make it bright", seed=seed)
    return b


def test_losses_are_differentiable_in_theta(models):
    b = _backend(models)
    parts = psa.psa_losses(b.forward(), models)
    total = parts["pc"] + parts["cs"] + parts["ps"]
    total.backward()
    assert b.gain.grad is not None and b.gain.grad.abs().sum() > 0
    assert all(p.grad is None for p in models.compensator.parameters())  # networks stay frozen


def test_psa_lowers_loss_stops_and_returns_best(models):
    settings = psa.PSASettings(lr=0.05, max_iterations=60, style_weight=0.0)
    result = psa.run_psa(_backend(models), models, settings)
    first = result.first_psa_loss  # the un-adapted look's (history[0] is after the warm start)
    best = min(result.history, key=lambda e: e["total"])
    assert result.best_iteration == best["iteration"]
    assert best["psa_loss"] < first
    # the stop rule: the first total at or under stop_ratio x the first loss ends the run (here the warm start's)
    stop = settings.stop_ratio * first
    assert result.stopped == "threshold" and result.history[-1]["total"] <= stop
    assert all(e["total"] > stop for e in result.history[:-1])
    assert result.iterations <= 60 and result.target.shape == (1, 3, SIZE, SIZE)
    assert not torch.equal(result.target, result.initial_target)


def test_style_weight_keeps_the_look(models):
    free = psa.run_psa(_backend(models), models, psa.PSASettings(max_iterations=15, style_weight=0.0, stop_ratio=0))
    kept = psa.run_psa(_backend(models), models, psa.PSASettings(max_iterations=15, style_weight=50.0, stop_ratio=0))
    drift = lambda r: float(((r.target - r.initial_target) ** 2).mean())  # noqa: E731
    assert drift(kept) < drift(free)


def test_deterministic_and_bad_settings(models):
    a = psa.run_psa(_backend(models), models, psa.PSASettings(max_iterations=5))
    b = psa.run_psa(_backend(models), models, psa.PSASettings(max_iterations=5))
    assert [e["total"] for e in a.history] == [e["total"] for e in b.history]
    with pytest.raises(ValueError, match="subset"):
        psa.run_psa(_backend(models), models, psa.PSASettings(terms=("bogus",)))


def test_cancel_event_stops_after_first_iterate(models):
    stop = threading.Event()
    seen = []

    def progress(p, m):
        seen.append(m)
        stop.set()

    result = psa.run_psa(_backend(models), models, psa.PSASettings(max_iterations=20, stop_ratio=0.0), on_progress=progress,
                         cancel_event=stop)
    assert result.stopped == "cancelled" and len(result.history) == 1


def test_the_resample_baseline_keeps_the_best_sample(models):
    settings = psa.PSASettings(max_iterations=4, stop_ratio=0.0)
    result = psa_resample.run_resample(_backend(models), models, settings)
    losses = [e["psa_loss"] for e in result.history]
    assert len(losses) == 5 and result.best_iteration == losses.index(min(losses))


def test_ablation_terms_and_loss_maps(models):
    for name, terms in psa_resample.ABLATIONS.items():
        r = psa.run_psa(_backend(models), models, psa.PSASettings(terms=terms, max_iterations=2))
        assert r.iterations <= 2, name
    maps = psa.loss_maps(_backend(models).forward(), models)
    assert maps["cs"].shape == (SIZE, SIZE) and maps["ps"].shape == (SIZE, SIZE)
    assert float(maps["ps"].sum()) > 0  # gain 1.6 pushes the target above I+


def test_cancel_before_start_still_returns_the_first_iterate(models):
    stop = threading.Event()
    stop.set()  # cancelled during the warm start: the un-moved field, one iterate, no traceback
    result = psa.run_psa(_backend(models), models, psa.PSASettings(max_iterations=20), cancel_event=stop)
    assert result.stopped == "cancelled" and len(result.history) == 1 and result.warm_start_steps == 0


def test_psa_losses_count_only_the_object_pixels(models):
    mask = torch.zeros(1, 1, SIZE, SIZE)
    mask[..., : SIZE // 2] = 1.0  # the object covers the left half of the frame
    masked = SurfaceModels(models.compensator, models.simulator, models.s, models.i_min, models.i_max,
                               on_object=mask)
    target = torch.rand(1, 3, SIZE, SIZE, generator=torch.Generator().manual_seed(3))
    changed = target.clone()
    changed[..., SIZE // 2:] = 1.0 - changed[..., SIZE // 2:]  # only off the object
    with torch.no_grad():
        a, b = psa.psa_losses(target, masked), psa.psa_losses(changed, masked)
        full_a, full_b = psa.psa_losses(target, models), psa.psa_losses(changed, models)
    # the compensator sees a neighbourhood, so the border columns may move a little
    for term in psa.LOSS_TERMS:
        assert float(a[term]) == pytest.approx(float(b[term]), rel=0.05, abs=1e-6)
    assert any(abs(float(full_a[t]) - float(full_b[t])) > 0.05 * abs(float(full_a[t])) for t in psa.LOSS_TERMS)


def test_a_valid_map_far_below_the_geometric_coverage_is_not_the_object():
    """On a near-black surface the Gray code decodes on the bright features only: that map must
    neither darken the object nor mask PSA's losses."""
    from types import SimpleNamespace

    from lapig.lapig_core import pipeline

    sparse = np.zeros((24, 32), bool)
    sparse[::6, ::6] = True  # 3% of the frame decoded
    dark = SimpleNamespace(projector_valid=sparse, meta={"coverage": {"projector_on_object": 1.0}})
    assert "only 3%" in pipeline.unreliable_footprint(dark)
    assert pipeline.psa_mask(dark) is None and pipeline.object_footprint(dark) is None
    statue = np.zeros((24, 32), bool)
    statue[4:20, 10:22] = True  # a statue's silhouette: 25% decoded, the geometry says 26%
    lit = SimpleNamespace(projector_valid=statue, meta={"coverage": {"projector_on_object": 0.26}})
    assert pipeline.unreliable_footprint(lit) is None
    assert float(pipeline.psa_mask(lit).sum()) == statue.sum()
    public = SimpleNamespace(projector_valid=None, meta={})
    assert pipeline.unreliable_footprint(public) is None and pipeline.psa_mask(public) is None


def test_resample_draws_different_samples_from_a_deterministic_backend(models):
    """A backend whose look depends on its seed only through jitter (as the offline style net): the
    baseline jitters theta for its new samples, or it would re-draw its first sample every time, and
    the backend's own jitter is left as it was."""

    class Deterministic(LGSTBackend):
        name = "deterministic-test"
        jitter = 0.0

        def prepare(self, surface, prompt, seed=0, mix=None):
            self.surface, self.prompt = surface, prompt
            noise = torch.randn(1, 3, 1, 1, generator=torch.Generator().manual_seed(seed))
            self.gain = (torch.ones(1, 3, 1, 1) + self.jitter * noise).requires_grad_(True)

        def parameters(self):
            return [self.gain]

        def forward(self):
            return (self.surface * self.gain).clamp(0, 1)

        def describe(self):
            return {"backend": self.name, "prompt": self.prompt, "styles": []}

    backend = Deterministic()
    backend.prepare(models.s, "p")
    result = psa_resample.run_resample(backend, models, psa.PSASettings(max_iterations=4, stop_ratio=0.0))
    losses = [e["psa_loss"] for e in result.history]
    assert len(set(round(v, 9) for v in losses)) == 5  # five different samples
    assert backend.jitter == 0.0 and result.best_iteration == losses.index(min(losses))
    with torch.no_grad():  # the backend is left on the best sample
        assert torch.allclose(backend.forward(), result.target)
