# SPDX-License-Identifier: GPL-3.0-or-later
"""The public code's PSA, the baseline the PSA benchmarks set beside the gradient PSA of
lapig_core.psa.adaptation, and the paper's loss ablation table.

`run_resample` re-samples the backend with new seeds until the PSA loss falls to stop_ratio x the
first sample's, at most settings.max_iterations samples (no tone field, no gradient). Reached by
tools/bench/bench_psa.py (variant "resample") and the tests; the add-on never runs it.
"""
from __future__ import annotations

import time

import torch

from ...lapig_core.psa.adaptation import LOSS_TERMS, PSAResult, PSASettings, check_terms, psa_loss, psa_losses

ABLATIONS = {  # name -> active PSA terms (the paper's Table 2)
    "L_pc": ("pc",), "L_cs": ("cs",), "L_ps": ("ps",), "L_ps+L_cs": ("ps", "cs"), "all": ("pc", "cs", "ps"),
}
# theta noise of each new sample: the offline backends are deterministic in their seed alone (the
# paper's InstructPix2Pix samples differ by seed), so without it every sample would be the first
RESAMPLE_JITTER = 0.1


def run_resample(backend, models, settings: PSASettings | None = None, on_progress=None, cancel_event=None,
                 jitter: float = RESAMPLE_JITTER) -> PSAResult:
    """The public code's PSA: new seeds until the loss is at most stop_ratio x the first sample's.

    Unlike the public code it returns the best sample seen, not the last one, and leaves the backend on it.
    """
    settings = settings or PSASettings()
    check_terms(settings)
    t0 = time.perf_counter()
    surface, prompt = getattr(backend, "surface", None), backend.describe().get("prompt", "")
    history, best, first, stopped, anchor = [], None, None, "max_iterations", None
    plain_jitter = getattr(backend, "jitter", None)
    for k in range(settings.max_iterations + 1):
        if cancel_event is not None and cancel_event.is_set():
            stopped = "cancelled"
            break
        if k > 0:
            _prepare_sample(backend, surface, prompt, settings.seed + k, plain_jitter, jitter)
        with torch.no_grad():
            target = backend.forward()
            anchor = target if anchor is None else anchor
            parts = psa_losses(target, models)
            psa = float(psa_loss(parts, settings))
        first = psa if first is None else first
        history.append({"iteration": k, "psa_loss": psa, **{t: float(parts[t]) for t in LOSS_TERMS}})
        if best is None or psa < best[0]:
            best = (psa, k, backend.state(), target, parts["comp"], parts["sim"])
        if on_progress:
            on_progress(min(k / settings.max_iterations, 1.0), f"PSA sample {k}: loss {psa:.5f}")
        if psa <= settings.stop_ratio * first and k > 0:
            stopped = "threshold"
            break
    _, k_best, state, target, comp, sim = best
    if k_best != len(history) - 1:
        if k_best == 0:  # the un-jittered first sample
            _prepare_sample(backend, surface, prompt, settings.seed, plain_jitter, 0.0)
        else:
            _prepare_sample(backend, surface, prompt, settings.seed + k_best, plain_jitter, jitter)
    return PSAResult(target, comp, sim, anchor, iterations=len(history) - 1, seconds=time.perf_counter() - t0,
                     history=history, best_iteration=k_best, stopped=stopped, state=state, look=backend)


def _prepare_sample(backend, surface, prompt, seed, plain_jitter, jitter):
    """Prepare one resample: a deterministic backend (jitter 0) gets `jitter` for this sample only."""
    if plain_jitter is not None and plain_jitter == 0.0:
        backend.jitter = jitter
        try:
            backend.prepare(surface, prompt, seed=seed)
        finally:
            backend.jitter = plain_jitter
    else:
        backend.prepare(surface, prompt, seed=seed)
