# SPDX-License-Identifier: GPL-3.0-or-later
"""Training loop, checkpoints and pretraining plumbing at 32 px (seconds, not minutes)."""
import threading

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric import checkpoints, finetune
from lapig.tools import pretrain
from lapig.lapig_core.capture.dataset import load_capture_set
from lapig.lapig_core.photometric.training import (COMPENNEST_FINETUNE, PCNET_TRAIN, Recipe, Trainer, TrainingError, evaluate_pairs)
from lapig.lapig_core.photometric.training_data import pairs_from_capture_sets

from test_dataset import make_dataset


@pytest.fixture
def capture_set(tmp_path):
    make_dataset(tmp_path, n_train=8, n_test=2)
    return load_capture_set(tmp_path)


def _recipe(n=6, **kw):
    return Recipe(n, batch_size=4, loss_schedule=((0, "l1"), (3, "l1+ssim")), **kw)


def test_paper_recipes_and_scaling():
    assert COMPENNEST_FINETUNE.loss_at(199) == "l1" and COMPENNEST_FINETUNE.loss_at(200) == "l1+ssim"
    assert PCNET_TRAIN.lr_steps == (1000,) and PCNET_TRAIN.loss_at(600) == "l1+l2+ssim"
    small = PCNET_TRAIN.scaled(300, crop=64)
    assert small.lr_steps == (200,) and small.loss_schedule == ((0, "l1+l2"), (120, "l1+l2+ssim"))
    assert small.crop == 64 and small.batch_size == 8 and small.weight_decay == 1e-4


def test_pairs_roles(capture_set):
    comp = pairs_from_capture_sets([capture_set], "compensation")
    sim = pairs_from_capture_sets([capture_set], "simulation", count=3)
    assert comp.x.shape == (8, 3, 32, 32) and len(sim) == 3
    assert torch.equal(comp.x[:3], sim.y) and torch.equal(comp.y[:3], sim.x)  # inverse mappings
    with pytest.raises(ValueError, match="role"):
        pairs_from_capture_sets([capture_set], "bogus")


@pytest.mark.parametrize("arch,role", [("CompenNeSt", "compensation"), ("PCNet", "simulation")])
def test_training_lowers_loss_and_is_deterministic(capture_set, arch, role):
    pairs = pairs_from_capture_sets([capture_set], role)
    runs = []
    for _ in range(2):
        model = checkpoints.new_model(arch, seed=3)
        before = evaluate_pairs(model, pairs)["psnr"]
        # at one thread count: the count changes float rounding, and the tuner's choice follows the machine's load
        result = Trainer(model, pairs, Recipe(30, batch_size=4, seed=1), report_every=10, tune_threads=False).run()
        runs.append((before, evaluate_pairs(model, pairs)["psnr"], result.history[-1]["loss"]))
    assert runs[0] == runs[1]  # same seed, same numbers
    assert runs[0][1] > runs[0][0] + 1.0


def test_progress_cancel_and_crop(capture_set):
    pairs = pairs_from_capture_sets([capture_set], "simulation")
    cancel = threading.Event()
    seen = []

    def on_progress(p, msg):
        seen.append(p)
        if len(seen) == 2:
            cancel.set()

    model = checkpoints.new_model("PCNet")
    result = Trainer(model, pairs, _recipe(50, crop=16), report_every=2, cancel_event=cancel).run(on_progress)
    assert result.cancelled and result.iterations == 4 and seen == [0.04, 0.08]
    with pytest.raises(TrainingError, match="multiple of 4"):
        Trainer(model, pairs, _recipe(crop=18))


def test_a_cancel_during_the_last_report_is_a_cancel(capture_set):
    """A job paused at the last report is cancelled there: no iteration follows to check it at the loop's top."""
    pairs = pairs_from_capture_sets([capture_set], "simulation")
    cancel = threading.Event()

    def on_progress(p, msg):
        if p >= 1.0:
            cancel.set()

    model = checkpoints.new_model("PCNet")
    result = Trainer(model, pairs, _recipe(4, crop=16), report_every=2, cancel_event=cancel).run(on_progress)
    assert result.cancelled


def test_cpu_training_times_its_steps_to_choose_threads_and_gives_the_count_back(capture_set):
    """On the CPU the steps run under a ThreadTuner: the result says at which counts they ran, and the worker's
    thread count is as before afterwards, a cancel included."""
    pairs = pairs_from_capture_sets([capture_set], "simulation")
    cancel = threading.Event()
    results, seen = [], []

    def worker():
        before = torch.get_num_threads()
        results.append(Trainer(checkpoints.new_model("PCNet"), pairs, _recipe(12, crop=16)).run())
        # cancelled in the first trial (steps 5-7), where the tuner has set a count of its own
        results.append(Trainer(checkpoints.new_model("PCNet"), pairs, _recipe(40, crop=16), report_every=1,
                               cancel_event=cancel).run(lambda p, m: cancel.set() if p >= 6 / 40 else None))
        results.append(Trainer(checkpoints.new_model("PCNet"), pairs, _recipe(6, crop=16), tune_threads=False).run())
        seen.append((before, torch.get_num_threads()))

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    full, cancelled, fixed = results
    assert seen[0][0] == seen[0][1]
    assert sum(full.threads["steps_at"].values()) == 12 and full.threads["start"] == seen[0][0]
    assert cancelled.cancelled and sum(cancelled.threads["steps_at"].values()) == 6
    if seen[0][0] > 1:
        assert cancelled.threads["trials"] == 0 and "1" in cancelled.threads["steps_at"]  # stopped mid-trial
    assert fixed.threads is None


def test_nan_guard_recovers_then_gives_up(capture_set):
    pairs = pairs_from_capture_sets([capture_set], "compensation")
    model = checkpoints.new_model("CompenNeSt")
    calls = {"n": 0}
    original = model.forward

    def flaky(*a, **k):  # one NaN batch: recover with the last good weights and go on
        calls["n"] += 1
        out = original(*a, **k)
        return out * float("nan") if calls["n"] == 3 else out

    model.forward = flaky
    result = Trainer(model, pairs, _recipe(6)).run()
    assert result.nan_recoveries == 1 and result.iterations == 6
    assert all(torch.isfinite(p).all() for p in model.parameters())

    model.forward = lambda *a, **k: original(*a, **k) * float("nan")
    with pytest.raises(TrainingError, match="diverged"):
        Trainer(model, pairs, _recipe(6)).run()


def test_checkpoint_header_and_refusals(tmp_path):
    model = checkpoints.new_model("PCNet", seed=1)
    path = checkpoints.save_checkpoint(tmp_path / "m.pt", model, "simulation", 256, "abc123", note="x")
    loaded, header = checkpoints.load_checkpoint(path, arch="PCNet", role="simulation", working_size=256,
                                                 fingerprint="abc123")
    assert header["arch"] == "PCNet" and header["fingerprint"] == "abc123" and header["note"] == "x"
    assert header["parameters"] == 1231767
    for a, b in zip(model.parameters(), loaded.parameters()):
        assert torch.equal(a, b)
    with pytest.raises(checkpoints.CheckpointError, match="holds a PCNet"):
        checkpoints.load_checkpoint(path, arch="CompenNeSt")
    with pytest.raises(checkpoints.CheckpointError, match="trained for simulation"):
        checkpoints.load_checkpoint(path, role="compensation")
    with pytest.raises(checkpoints.CheckpointError, match="trained at 256 px"):
        checkpoints.load_checkpoint(path, working_size=128)
    with pytest.raises(checkpoints.CheckpointError, match="another setup"):
        checkpoints.load_checkpoint(path, fingerprint="other")
    (tmp_path / "bad.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(checkpoints.CheckpointError, match="not a readable checkpoint"):
        checkpoints.load_checkpoint(tmp_path / "bad.pt")
    torch.save({"weights": 1}, tmp_path / "plain.pt")
    with pytest.raises(checkpoints.CheckpointError, match="no header"):
        checkpoints.load_checkpoint(tmp_path / "plain.pt")
    with pytest.raises(checkpoints.CheckpointError, match="no checkpoint"):
        checkpoints.load_checkpoint(tmp_path / "missing.pt")


def test_new_model_is_seeded_and_leaves_global_rng():
    torch.manual_seed(5)
    expected = torch.rand(1)
    torch.manual_seed(5)
    a = checkpoints.new_model("CompenNeSt", seed=7)
    assert torch.equal(torch.rand(1), expected)
    b = checkpoints.new_model("CompenNeSt", seed=7)
    assert all(torch.equal(p, q) for p, q in zip(a.parameters(), b.parameters()))


def test_shipped_pretrained_weights_load_and_are_small():
    for (arch, role), name in checkpoints.PRETRAINED.items():
        path = checkpoints.WEIGHTS_DIR / name
        if not path.exists():
            pytest.skip("pretrained weights not built yet")
        model, header = checkpoints.load_pretrained(arch, role)
        assert header["fingerprint"] is None and header["working_size"] == 256
        assert checkpoints.file_size_mb(path) < 10


def test_pretrain_and_finetune_plumbing(tmp_path, capture_set):
    sets = [capture_set, capture_set]
    out = tmp_path / "weights"
    summary = pretrain.pretrain_one(sets, "PCNet", "simulation", 4, out, crop=16, warmup=0, val_count=2)
    assert summary["pairs"] == 16 and (out / "pcnet_pretrained.pt").exists()
    pretrain.pretrain_one(sets, "CompenNeSt", "compensation", 4, out, crop=16, warmup=2, val_count=2)
    model, result = finetune.finetune(capture_set, "CompenNeSt", "compensation",
                                      recipe=finetune.cpu_recipe("CompenNeSt", "compensation", 4).__class__(
                                          4, batch_size=4, crop=16), val_count=2, eval_every=2, weights_dir=out)
    assert result.iterations == 4 and "val_psnr" in result.history[-1]
    path = finetune.save_setup_model(tmp_path / "setup", model, "compensation", capture_set)
    finetune.load_setup_model(tmp_path / "setup", "CompenNeSt", "compensation",
                              fingerprint=capture_set.meta.get("fingerprint"))
    with pytest.raises(checkpoints.CheckpointError, match="pretrained CompenNeSt"):
        finetune.start_model("CompenNeSt", "compensation", weights_dir=tmp_path / "nowhere")
    assert path.exists()


def test_finetune_at_a_working_size_below_the_crop(capture_set, tmp_path):
    out = tmp_path / "weights"
    pretrain.pretrain_one([capture_set], "PCNet", "simulation", 2, out, crop=16, warmup=0, val_count=1)
    model, result = finetune.finetune(capture_set, "PCNet", "simulation", weights_dir=out,
                                      recipe=finetune.cpu_recipe("PCNet", "simulation", 2))  # crop 64 > 32 px
    assert result.iterations == 2


def test_the_compensation_fine_tune_measures_its_error_as_the_camera_sees_it(capture_set):
    from lapig.lapig_core.photometric.classical import ClassicalModel
    from lapig.lapig_core.photometric.training import CAMERA_LOSS

    recipe = finetune.cpu_recipe("CompenNeSt", "compensation", 20)
    assert recipe.loss_schedule == ((0, CAMERA_LOSS),) and recipe.lr_steps == (14,) and finetune.cpu_recipe("CompenNeSt", "compensation").iterations == 1000 and recipe.weight_decay == 0
    paper = finetune.cpu_recipe("CompenNeSt", "compensation", 20, loss=finetune.PAPER_LOSS)
    assert paper.loss_at(19) == "l1+ssim"
    assert finetune.cpu_recipe("PCNet", "simulation", 20).loss_at(0) == "l1+l2"  # already in camera space
    with pytest.raises(ValueError, match="unknown fine-tuning loss"):
        finetune.cpu_recipe("CompenNeSt", "compensation", loss="l7")

    pairs = pairs_from_capture_sets([capture_set], "compensation")
    with pytest.raises(TrainingError, match="classical model"):
        Trainer(finetune.start_model("CompenNeSt", "compensation"), pairs, recipe)
    classical = ClassicalModel.fit(capture_set.prj_train, capture_set.cam_train)
    camera = finetune.camera_space_loss(capture_set, classical)
    assert camera.size == (32, 32) and 0 < float(camera.weight.mean()) <= 1
    two = pairs_from_capture_sets([capture_set, capture_set], "compensation")
    with pytest.raises(TrainingError, match="one setup's"):
        Trainer(finetune.start_model("CompenNeSt", "compensation"), two, recipe, camera_loss=camera)
    with pytest.raises(TrainingError, match="camera-space loss is 16x16"):
        Trainer(finetune.start_model("CompenNeSt", "compensation"), pairs, recipe,
                camera_loss=camera.cropped(slice(0, 16), slice(0, 16)))

    def camera_error(model):
        from lapig.lapig_core.photometric.training import predict
        return float(camera(predict(model, pairs.x, capture_set_surface(capture_set)), pairs.y))

    start = finetune.start_model("CompenNeSt", "compensation")
    before = camera_error(start)
    model, result = finetune.finetune(capture_set, "CompenNeSt", "compensation", recipe=recipe, classical=classical)
    assert result.iterations == 20 and camera_error(model) < 0.8 * before
    # without a classical model given, the fine-tune fits one on the same pairs
    _, result = finetune.finetune(capture_set, "CompenNeSt", "compensation", count=4,
                                  recipe=finetune.cpu_recipe("CompenNeSt", "compensation", 2))
    assert result.iterations == 2


def capture_set_surface(cs):
    from lapig.lapig_core.photometric.training_data import SurfaceTensors
    return SurfaceTensors.from_capture_set(cs).s
