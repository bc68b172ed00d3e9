"""`python -m lapig_addon bench pcnet-through --json [--realistic-setups NAME,...]`: CompenNeSt trained further
through the setup's fine-tuned PCNet, rendered beside the app's fine-tune and the classical compensation.

A design study for issue 16 (not a path of the app). After the app's fine-tune (camera-space loss), 300 more
iterations (Adam 2e-4, x0.2 at 70 %, 64 px crops) minimise the camera-space loss on the training pairs plus
|PCNet(CompenNeSt(t)) - t| over desired targets t made from the training images (photometric/targets), PCNet
frozen: the compensation is then also judged by a model of the capture with spatial context, on the kind of
image it will compensate. `pcnet_only` drops the camera-space term. Each is rendered on the same 8 test targets
as `bench transport` (masked PSNR), and PCNet's own rating of every compensation is reported beside it.
"""
from __future__ import annotations

import copy
import os
import platform
import time

import numpy as np
import torch

from .. import synthetic_setups as syn
from .bench_learned_variants import crop_steps
from .bench_transport import _log, compensation_case, realistic_specs

EXTRA_ITERATIONS = 300


def train_through_pcnet(app, pcnet, cs, surf, camera_loss, reach, iterations=EXTRA_ITERATIONS, pcnet_weight=1.0,
                        camera_weight=1.0, seed=0, crop=64):
    """A copy of `app` trained further on camera_weight * camera-space loss + pcnet_weight * the masked l1 of
    PCNet's simulated capture of its compensation against the desired target."""
    from ...lapig_core.photometric.targets import desired_targets
    from ...lapig_core.photometric.training_data import to_tensor

    model = copy.deepcopy(app)
    for p in pcnet.parameters():
        p.requires_grad_(False)
    pcnet.eval()
    x, y = to_tensor(cs.cam_train), to_tensor(cs.prj_train)
    t_all = to_tensor(desired_targets(cs.prj_train, cs.cam_black, cs.cam_white, reach))
    w = torch.from_numpy(reach.astype(np.float32))[None, None]
    opt = torch.optim.Adam(model.parameters(), lr=2e-4)
    for idx, rows, cols in crop_steps(opt, len(x), *x.shape[-2:], iterations, crop, 4e-5, seed):
        sl = (Ellipsis, rows, cols)
        model.train()
        s = surf.s[sl].expand(len(idx), -1, -1, -1)
        loss = 0.0
        if camera_weight:
            loss = camera_weight * camera_loss.cropped(rows, cols)(model(x[idx][sl], s), y[idx][sl])
        if pcnet_weight:
            t = t_all[idx][sl]
            seen = pcnet(model(t, s), s, surf.i_min[sl], surf.i_max[sl])
            m = w[sl]
            loss = loss + pcnet_weight * ((seen - t).abs() * m).sum() / (m.sum() * 24 + 1)
        opt.zero_grad()
        loss.backward()
        opt.step()
    model.eval()
    return model


def run(args) -> dict:
    from .projection_render import render_working_images
    from ...lapig_core.common import metrics
    from ...lapig_core.photometric.finetune import camera_space_loss, cpu_recipe, finetune
    from ...lapig_core.photometric.training import predict
    from ...lapig_core.photometric.training_data import to_numpy, to_tensor
    from ...lapig_core.capture.dataset import setup_dir_of

    t0 = time.perf_counter()
    data = os.path.abspath(args.transport_data)
    specs = realistic_specs(args)
    syn.render_synthetic_setups(specs, data, train=args.train_pairs, test=args.test_pairs, seed=600,
                                skip_existing=True)
    weights = getattr(args, "weights", None)
    per_setup = {}
    for spec in specs:
        cs, surf, mask, targets, classical = compensation_case(args, data, spec)
        count = len(targets)
        pcnet, _ = finetune(cs, "PCNet", "simulation", recipe=cpu_recipe("PCNet", "simulation", args.iterations),
                            weights_dir=weights)
        app, _ = finetune(cs, "CompenNeSt", "compensation", classical=classical, weights_dir=weights,
                          recipe=cpu_recipe("CompenNeSt", "compensation", args.iterations))
        images = {"classical": classical.compensate(targets), "app": to_numpy(predict(app, to_tensor(targets), surf.s))}
        seconds = {}
        camera = camera_space_loss(cs, classical)
        for name, camera_weight in (("through_pcnet", 1.0), ("pcnet_only", 0.0)):
            t = time.perf_counter()
            model = train_through_pcnet(app, pcnet, cs, surf, camera, mask, camera_weight=camera_weight)
            images[name] = to_numpy(predict(model, to_tensor(targets), surf.s))
            seconds[name] = round(time.perf_counter() - t, 1)
        names = list(images)
        rated = {}
        for k in names:  # what PCNet says the camera would see
            seen = to_numpy(predict(pcnet, to_tensor(np.clip(images[k], 0, 1)), surf.s, surf.i_min, surf.i_max))
            rated[k] = round(metrics.masked_psnr(seen, targets, mask), 4)
        scene, projector, camera_obj, target = syn.build_setup(spec, os.path.join(data, "textures"))
        rendered = render_working_images(scene, projector, camera_obj, target, setup_dir_of(cs),
                                         np.concatenate([images[k] for k in names]), seed=7)
        row = {"rendered_psnr_masked": {k: round(metrics.masked_psnr(rendered[i * count:(i + 1) * count], targets,
                                                                     mask), 4) for i, k in enumerate(names)},
               "pcnet_rated_psnr_masked": rated, "extra_train_seconds": seconds}
        for k in names[1:]:
            row[f"{k}_minus_classical_db"] = round(row["rendered_psnr_masked"][k]
                                                   - row["rendered_psnr_masked"]["classical"], 4)
        per_setup[spec.name] = row
        _log(args, f"{spec.name}: {row}")
    summary = {"per_setup": per_setup, "extra_iterations": EXTRA_ITERATIONS}
    for k in ("app", "through_pcnet", "pcnet_only"):
        summary[f"{k}_minus_classical_db_mean"] = round(float(np.mean(
            [r[f"{k}_minus_classical_db"] for r in per_setup.values()])), 4)
    summary.update({"bench_total_s": round(time.perf_counter() - t0, 1), "cpu_threads": torch.get_num_threads(),
                    "machine": platform.processor() or platform.machine(),
                    "pretrained_weights": weights or "shipped"})
    return summary
