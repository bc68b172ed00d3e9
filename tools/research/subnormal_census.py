"""Where the subnormal floats of Train are (issue 37; BENCHMARKS "Train's cost on the CPU: subnormal floats"): the
shipped pretrained weights' count, then each network's fine-tune as Train runs it (the app's recipes: CompenNeSt
with the camera-space loss, PCNet with the paper's loss and weight decay) on one capture, on a thread WITHOUT
flush-to-zero and with the Trainer's periodic scrub switched off, counting the subnormal weights and Adam moments
after steps 1, 10, 50, 100, 200 and the last. Prints one JSON line.
Run: .venv/bin/python tools/research/subnormal_census.py CAPTURE_FOLDER [iterations=300]  (about a minute)"""
import importlib.util, sys, pathlib, json
import torch
ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.lapig_core.common import adam as adam_mod, denormals
from lapig.lapig_core.capture.dataset import load_capture_set
from lapig.lapig_core.photometric import finetune as ft, training
from lapig.lapig_core.photometric.classical import ClassicalModel
from lapig.lapig_core.photometric.training_data import pairs_from_capture_sets
from lapig.tools.bench.bench_denormals import _raw_model

cs = load_capture_set(sys.argv[1])
iterations = int(sys.argv[2]) if len(sys.argv) > 2 else 300
step, log = adam_mod.Adam.step, []


def counted(self):
    step(self)
    log.append((denormals.count(p for g in self.param_groups for p in g["params"]), denormals.count(self.moments())))


adam_mod.Adam.step = counted
training.SCRUB_EVERY = 10 ** 9  # what training makes when nothing clears it
out = {"capture": sys.argv[1], "iterations": iterations}
for arch, role in (("CompenNeSt", "compensation"), ("PCNet", "simulation")):
    raw = _raw_model(arch, role)
    weights = sum(p.numel() for p in raw.parameters())
    shipped = denormals.count(raw.parameters())
    tiny_normal = sum(int(((p != 0) & (p.abs() < 1e-20)).sum()) for p in raw.parameters())
    log.clear()
    model = ft.start_model(arch, role)  # scrubbed at load, as the app loads it
    recipe = ft.cpu_recipe(arch, role, iterations=iterations)
    camera = ft.camera_space_loss(cs, ClassicalModel.fit(cs.prj_train, cs.cam_train)) if recipe.needs_camera_loss else None
    training.Trainer(model, pairs_from_capture_sets([cs], role), recipe, camera_loss=camera, report_every=1000).run()
    at = {str(i + 1): {"weights": log[i][0], "moments": log[i][1]} for i in (0, 9, 49, 99, 199, len(log) - 1)
          if i < len(log)}
    out[arch] = {"weights": weights, "moments": 2 * weights, "subnormal_weights_shipped": shipped,
                 "weights_below_1e-20_shipped": tiny_normal, "weight_decay": recipe.weight_decay,
                 "after_step": at}
    print(arch, out[arch], file=sys.stderr)
print(json.dumps(out))
