"""`python -m lapig_addon bench learned-variants --json [--realistic-setups NAME,...]`: three ways of making
the learned compensation beat the per-pixel (classical) one on the realistic setups, rendered side by side.

A design study for issue 16 (not a path of the app). Each variant is fitted on all the captured training pairs of
a realistic setup (rendered on first use, the same captures as `bench transport`), then 8 test images are
compensated, projected and captured through the same rig (masked PSNR against the target, as `bench transport`),
also split into the pixels the classical model reaches and those where it would clip the projector:
  * classical: the per-pixel model (the reference);
  * compennest: CompenNeSt with the paper's loss (projector-space l1, then l1+SSIM; the CPU recipe), as the app
    fine-tuned it before it took the camera-space loss of the next variant;
  * compennest_camera_loss: the same network, start and budget, with the error measured as the camera sees it,
    M (f_p(P_hat) - f_p(P)) through the setup's classical M and gamma_p, over the projector-reachable pixels
    (this study's own loop; the app's fine-tune now uses losses.CameraSpaceLoss, the same loss);
    In projector space the loss is ruled by dark pixels, where capture noise maps to large projector errors;
  * residual_on_classical: the classical compensation plus a small CNN's correction (zero at the start), with
    the camera-space loss: it cannot start worse than the classical model, and learns what the per-pixel model
    leaves (bounce light, blur, scattering) where the training pairs show it.
"""
from __future__ import annotations

import os
import platform
import time

import numpy as np
import torch
from torch import nn

from .. import synthetic_setups as syn
from .bench_transport import _log, compensation_case, psnr_over, realistic_specs

ITERATIONS = 300


class ResidualOnClassical(nn.Module):
    """clamp(base + correction(x, base, s)): base is the classical compensation, given as channels 3-5 of x."""

    def __init__(self, width: int = 32):
        super().__init__()
        self.body = nn.Sequential(
            nn.Conv2d(9, width, 3, 1, 1), nn.ReLU(),
            nn.Conv2d(width, width, 3, 1, 2, dilation=2), nn.ReLU(),
            nn.Conv2d(width, width, 3, 1, 4, dilation=4), nn.ReLU(),
            nn.Conv2d(width, width, 3, 1, 1), nn.ReLU())
        self.head = nn.Conv2d(width, 3, 3, 1, 1)
        nn.init.zeros_(self.head.weight)  # starts as the classical compensation
        nn.init.zeros_(self.head.bias)

    def forward(self, x6, s):
        x, base = x6[:, :3], x6[:, 3:]
        return (base + self.head(self.body(torch.cat([x, base, s.expand_as(x)], 1)))).clamp(0, 1)


def crop_steps(opt, n: int, h: int, w: int, iterations: int, crop: int, lr_after: float, seed: int = 0):
    """The study's loop: for each iteration, (batch indices, rows, cols): a batch of 8 of the n pairs and a random
    crop aligned to 4 px, drawn from one seeded generator; the learning rate drops to lr_after at 70 %."""
    gen = torch.Generator().manual_seed(seed)
    for it in range(iterations):
        if it == int(iterations * 0.7):
            for group in opt.param_groups:
                group["lr"] = lr_after
        idx = torch.randint(n, (min(8, n),), generator=gen)
        top = int(torch.randint(0, h - crop + 1, (1,), generator=gen)) // 4 * 4
        left = int(torch.randint(0, w - crop + 1, (1,), generator=gen)) // 4 * 4
        yield idx, slice(top, top + crop), slice(left, left + crop)


def train_camera_loss(model, x, y, s, camera_loss, iterations=ITERATIONS, crop=64, seed=0):
    """Adam 1e-3 (x0.2 at 70 %), batch 8, random crops; camera_loss: the setup's losses.CameraSpaceLoss,
    |M (P_hat^gp - P^gp)| over the reachable pixels (finetune.camera_space_loss)."""
    opt = torch.optim.Adam(model.parameters(), lr=1e-3)
    for idx, rows, cols in crop_steps(opt, len(x), *x.shape[-2:], iterations, crop, 2e-4, seed):
        model.train()
        pred = model(x[idx][..., rows, cols], s[..., rows, cols])
        loss = camera_loss.cropped(rows, cols)(pred, y[idx][..., rows, cols])
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
    model.eval()
    return model


def run(args) -> dict:
    from .projection_render import render_working_images
    from ...lapig_core.photometric.finetune import PAPER_LOSS, camera_space_loss, cpu_recipe, finetune, start_model
    from ...lapig_core.photometric.training import predict
    from ...lapig_core.photometric.training_data import to_numpy, to_tensor
    from ...lapig_core.capture.dataset import setup_dir_of

    t0 = time.perf_counter()
    torch.manual_seed(0)
    data = os.path.abspath(args.transport_data)
    iterations = args.iterations or ITERATIONS
    specs = realistic_specs(args)
    syn.render_synthetic_setups(specs, data, train=args.train_pairs, test=args.test_pairs, seed=600,
                                skip_existing=True)

    per_setup = {}
    for spec in specs:
        cs, surf, mask, targets, classical = compensation_case(args, data, spec)
        count = len(targets)
        camera_loss = camera_space_loss(cs, classical)
        x, y = to_tensor(cs.cam_train), to_tensor(cs.prj_train)
        images, seconds = {"classical": classical.compensate(targets)}, {}

        t = time.perf_counter()
        model, _ = finetune(cs, "CompenNeSt", "compensation",
                            recipe=cpu_recipe("CompenNeSt", "compensation", iterations, loss=PAPER_LOSS),
                            weights_dir=getattr(args, "weights", None))
        images["compennest"] = to_numpy(predict(model, to_tensor(targets), surf.s))
        seconds["compennest"] = round(time.perf_counter() - t, 1)

        t = time.perf_counter()
        model = train_camera_loss(start_model("CompenNeSt", "compensation", weights_dir=getattr(args, "weights", None)),
                                  x, y, surf.s, camera_loss, iterations, crop=64)
        images["compennest_camera_loss"] = to_numpy(predict(model, to_tensor(targets), surf.s))
        seconds["compennest_camera_loss"] = round(time.perf_counter() - t, 1)

        t = time.perf_counter()
        base = to_tensor(classical.compensate(cs.cam_train))
        model = train_camera_loss(ResidualOnClassical(), torch.cat([x, base], 1), y, surf.s, camera_loss,
                                  iterations, crop=96)
        x6 = torch.cat([to_tensor(targets), to_tensor(images["classical"])], 1)
        images["residual_on_classical"] = to_numpy(predict(model, x6, surf.s))
        seconds["residual_on_classical"] = round(time.perf_counter() - t, 1)

        images["uncompensated"] = targets
        names = list(images)
        scene, projector, camera, target = syn.build_setup(spec, os.path.join(data, "textures"))
        rendered = render_working_images(scene, projector, camera, target, setup_dir_of(cs),
                                         np.concatenate([images[k] for k in names]), seed=7)
        reach = classical.reachable(targets) & mask[None]
        row = {"reachable_share": round(float(reach.sum() / max(1, mask.sum() * count)), 4),
               "train_seconds": seconds}
        for i, k in enumerate(names):
            cap = rendered[i * count:(i + 1) * count]
            row[k] = {"psnr_masked": psnr_over(cap, targets, mask), "psnr_reachable": psnr_over(cap, targets, reach),
                      "psnr_unreachable": psnr_over(cap, targets, mask[None] & ~reach)}
        for k in names[1:-1]:
            row[f"{k}_minus_classical_db"] = round(row[k]["psnr_masked"] - row["classical"]["psnr_masked"], 4)
        per_setup[spec.name] = row
        _log(args, f"{spec.name}: {row}")
    summary = {"per_setup": per_setup, "iterations": iterations}
    for k in ("compennest", "compennest_camera_loss", "residual_on_classical"):
        summary[f"{k}_minus_classical_db_mean"] = round(float(np.mean(
            [r[f"{k}_minus_classical_db"] for r in per_setup.values()])), 4)
    summary.update({"bench_total_s": round(time.perf_counter() - t0, 1), "cpu_threads": torch.get_num_threads(),
                    "machine": platform.processor() or platform.machine(),
                    "pretrained_weights": getattr(args, "weights", None) or "shipped"})
    return summary
