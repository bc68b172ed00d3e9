# SPDX-License-Identifier: GPL-3.0-or-later
"""The one-step look (issue 53, item 4): the fast path's preview and, on Generate, PSA's look, on a tiny one-step
pipeline (random weights, made here): seeded, it follows the prompt, and PSA's gradients reach its theta."""
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("diffusers")
pytest.importorskip("transformers")

from lapig.lapig_core.lgst import get_backend
from lapig.tools.bench.tiny_pipeline import make_tiny_pipeline


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    return make_tiny_pipeline(tmp_path_factory.mktemp("turbo") / "sd-turbo", "img2img")


def test_the_one_step_look_is_seeded_follows_the_prompt_and_takes_psa_gradients(model):
    look = get_backend("one-step", model=model, size=64, device="cpu")
    surface = torch.rand(1, 3, 48, 64, generator=torch.Generator().manual_seed(0))
    a = look.stylize(surface, "a stained glass window", seed=2)
    assert a.shape == (1, 3, 48, 64) and torch.equal(a, look.stylize(surface, "a stained glass window", seed=2))
    assert float((a - look.stylize(surface, "a charcoal drawing", seed=2)).abs().mean()) > 1e-4
    assert float((a - look.stylize(surface, "a stained glass window", seed=3)).abs().mean()) > 1e-4
    look.prepare(surface, "a stained glass window", seed=2)
    assert look.describe()["timestep"] == 499  # SD-Turbo's image-to-image: 2 steps x strength 0.5
    look.forward().mean().backward()
    assert float(look.parameters()[0].grad.abs().sum()) > 0


def test_psa_adapts_the_one_step_look(model):
    from lapig.lapig_core.photometric.checkpoints import new_model
    from lapig.lapig_core.photometric.surface_models import SurfaceModels
    from lapig.lapig_core.psa.adaptation import PSASettings, run_psa

    surface = torch.rand(1, 3, 32, 32, generator=torch.Generator().manual_seed(1)) * 0.6 + 0.2
    models = SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), surface, surface * 0.1, surface * 0.9)
    look = get_backend("one-step", model=model, size=32, device="cpu")
    look.prepare(surface, "a mosaic", seed=0)
    result = run_psa(look, models, PSASettings(max_iterations=2, warm_start_steps=0, tone_field=False, seed=0,
                                               stop_ratio=0.0))
    assert result.iterations == 2 and result.target.shape == (1, 3, 32, 32)
    totals = [entry["total"] for entry in result.history]
    assert totals[1] != totals[0]  # theta alone is optimised (no tone field): its step changed the look
