# SPDX-License-Identifier: GPL-3.0-or-later
"""lapig_core.common.denormals: no subnormal weight reaches torch's CPU work (they cost some CPUs several times)."""
import threading

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.capture.dataset import load_capture_set  # noqa: E402
from lapig.lapig_core.common import denormals  # noqa: E402
from lapig.lapig_core.photometric import checkpoints  # noqa: E402
from lapig.lapig_core.photometric.training import SCRUB_EVERY, Recipe, Trainer  # noqa: E402
from lapig.lapig_core.photometric.training_data import pairs_from_capture_sets  # noqa: E402

from test_dataset import make_dataset  # noqa: E402

SUBNORMAL = 1e-40  # float32 holds it only as a subnormal


def _seed_subnormals(model, every=97):
    """Every `every`-th weight of each parameter set to a subnormal (a few in every layer); how many."""
    n = 0
    with torch.no_grad():
        for p in model.parameters():
            flat = p.view(-1)
            flat[::every] = SUBNORMAL
            n += flat[::every].numel()
    return n


def _underflow_share_in_fresh_thread(set_mode: bool) -> float:
    """In a new thread: the share of a large product of normal floats (1e-30 x 1e-10) left subnormal. Large
    enough that torch splits it over its threads, so a mode only the calling thread has shows as a share."""
    out = {}

    def run():
        if set_mode:
            assert denormals.flush_in_this_thread()
        y = torch.full((4_000_000,), 1e-30) * 1e-10
        out["share"] = float((y != 0).float().mean())
    t = threading.Thread(target=run)
    t.start()
    t.join()
    return out["share"]


def test_count_and_scrub_touch_only_the_subnormal_entries():
    t = torch.tensor([0.0, 1e-40, -1e-41, 1.2e-38, 1e-30, 1.0, -2.0])
    assert denormals.count([t, torch.arange(3)]) == 2  # integer tensors are skipped
    assert denormals.scrub([t]) == 2
    assert t.tolist() == pytest.approx([0.0, 0.0, 0.0, 1.2e-38, 1e-30, 1.0, -2.0], rel=1e-6, abs=0)
    assert denormals.count([t]) == 0


def test_count_and_scrub_see_subnormals_on_a_thread_that_treats_them_as_zero():
    """The add-on's workers run with denormals-are-zero, where a subnormal compares equal to 0: a checkpoint loaded
    there must still come out clean (and bench denormals, run inside the device check, counts them there)."""
    out = {}
    # made here, on a thread without the mode (made there, the float32 ones would be flushed as they are converted)
    t = torch.tensor([0.0, 1e-40, -1e-41, 1.2e-38, 1.0], dtype=torch.float32)
    d = torch.tensor([0.0, 1e-310, 2.3e-308, 1.0], dtype=torch.float64)  # 2.3e-308: the smallest normal's side

    def run():
        if not denormals.flush_in_this_thread():
            out["skip"] = True
            return
        out["count"] = denormals.count([t, d])
        out["scrubbed"] = denormals.scrub([t, d])
        out["bits"] = t.view(torch.int32).tolist(), d.view(torch.int64).tolist()

    worker = threading.Thread(target=run)
    worker.start()
    worker.join()
    if out.get("skip"):
        pytest.skip("this CPU has no flush-to-zero mode")
    assert out["count"] == 3 and out["scrubbed"] == 3
    floats, doubles = out["bits"]
    assert floats[1] == floats[2] == 0 and floats[3] != 0 and doubles[1] == 0 and doubles[2] != 0
    assert float(t[3]) == pytest.approx(1.2e-38) and float(t[4]) == 1.0  # the normal ones untouched


def test_flush_mode_covers_the_threads_torch_starts_from_a_fresh_worker():
    if not _underflow_share_in_fresh_thread(False):
        pytest.skip("this CPU flushes subnormals already")
    assert _underflow_share_in_fresh_thread(True) == 0.0


def test_checkpoints_load_without_subnormal_weights_and_with_the_rest_unchanged(tmp_path):
    model = checkpoints.new_model("CompenNeSt", seed=0)
    seeded = _seed_subnormals(model)
    assert denormals.count(model.parameters()) == seeded > 0
    path = checkpoints.save_checkpoint(tmp_path / "c.pt", model, "compensation", 32)
    loaded, _ = checkpoints.load_checkpoint(path)
    assert denormals.count(denormals.module_tensors(loaded)) == 0
    for a, b in zip(model.parameters(), loaded.parameters()):
        keep = a.abs() >= torch.finfo(torch.float32).tiny
        assert torch.equal(a[keep], b[keep]) and not b[~keep].any()


@pytest.mark.parametrize("arch", ["CompenNeSt", "PCNet"])
def test_shipped_pretrained_weights_load_clean(arch):
    role = "compensation" if arch == "CompenNeSt" else "simulation"
    model, _ = checkpoints.load_pretrained(arch, role)
    assert denormals.count(denormals.module_tensors(model)) == 0


def test_training_keeps_weights_and_moments_clean(tmp_path, monkeypatch):
    """Whatever makes subnormals while training (a thread without flush-to-zero: decaying dead weights, the
    squares of tiny gradients), Train sets them to zero every SCRUB_EVERY iterations and at the end. Here every
    step leaves one in every weight and moment tensor."""
    make_dataset(tmp_path, n_train=8, n_test=2)
    pairs = pairs_from_capture_sets([load_capture_set(tmp_path)], "simulation")
    model = checkpoints.new_model("PCNet", seed=1)
    _seed_subnormals(model)
    seen = []
    from lapig.lapig_core.common import adam

    step = adam.Adam.step

    def leaky(self):
        params = [p for g in self.param_groups for p in g["params"]]
        seen.append((denormals.count(params), denormals.count(self.moments())))
        step(self)
        with torch.no_grad():
            for t in params + self.moments():
                t.view(-1)[0] = SUBNORMAL
    monkeypatch.setattr(adam.Adam, "step", leaky)
    recipe = Recipe(SCRUB_EVERY + 3, batch_size=4, weight_decay=1e-4, loss_schedule=((0, "l1"),))
    Trainer(model, pairs, recipe, report_every=100).run()
    assert seen[0] == (0, 0)  # the seeded weights scrubbed before the first step
    assert seen[SCRUB_EVERY - 1][0] > 0 and seen[SCRUB_EVERY - 1][1] > 0  # made by the steps before
    assert seen[SCRUB_EVERY] == (0, 0)  # just after the scrub
    assert seen[SCRUB_EVERY + 1][0] > 0
    assert denormals.count(denormals.module_tensors(model)) == 0  # and at the end
