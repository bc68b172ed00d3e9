"""Tests for lapig_core.losses and lapig_core.metrics."""
import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric import losses
from lapig.lapig_core.common import metrics


def _ref_ssim(x, y):
    """Direct SSIM: 11x11 Gaussian (sigma 1.5) window slid over the valid region,
    per channel, C1=0.01^2, C2=0.03^2, mean of all windows. x, y: HxWxC float64."""
    r = np.arange(11) - 5
    g = np.exp(-r ** 2 / (2 * 1.5 ** 2))
    w = np.outer(g, g)
    w /= w.sum()
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    vals = []
    for c in range(x.shape[2]):
        for i in range(x.shape[0] - 10):
            for j in range(x.shape[1] - 10):
                a, b = x[i:i + 11, j:j + 11, c], y[i:i + 11, j:j + 11, c]
                ma, mb = (w * a).sum(), (w * b).sum()
                va, vb = (w * (a - ma) ** 2).sum(), (w * (b - mb) ** 2).sum()
                cov = (w * (a - ma) * (b - mb)).sum()
                vals.append((2 * ma * mb + c1) * (2 * cov + c2) / ((ma ** 2 + mb ** 2 + c1) * (va + vb + c2)))
    return float(np.mean(vals))


def _rand_pair(seed, h=24, w=20, noise=0.2):
    rng = np.random.default_rng(seed)
    x = rng.random((h, w, 3))
    y = np.clip(x + noise * rng.standard_normal((h, w, 3)), 0, 1)
    return x, y


def _nchw(a):
    return torch.from_numpy(a).permute(2, 0, 1)[None]


# -- metrics ---------------------------------------------------------------------

def test_ssim_identical_is_one():
    x, _ = _rand_pair(0)
    assert metrics.ssim(x, x) == pytest.approx(1.0, abs=1e-12)
    assert float(losses.ssim(_nchw(x).float(), _nchw(x).float())) == pytest.approx(1.0, abs=1e-5)
    assert float(losses.ssim_loss(_nchw(x).float(), _nchw(x).float())) == pytest.approx(0.0, abs=1e-5)


@pytest.mark.parametrize("seed,noise", [(1, 0.05), (2, 0.3), (3, 1.0)])
def test_ssim_matches_direct_reference(seed, noise):
    x, y = _rand_pair(seed, noise=noise)
    ref = _ref_ssim(x, y)
    assert metrics.ssim(x, y) == pytest.approx(ref, abs=1e-4)  # numpy, channel-last
    assert metrics.ssim(_nchw(x), _nchw(y)) == pytest.approx(ref, abs=1e-4)  # torch, channel-first
    # Training loss (pytorch-msssim or fallback) uses the same definition.
    assert float(losses.ssim(_nchw(x).float(), _nchw(y).float())) == pytest.approx(ref, abs=1e-4)


def test_own_ssim_matches_pytorch_msssim():
    pm = pytest.importorskip("pytorch_msssim")
    g = torch.Generator().manual_seed(0)
    x = torch.rand(2, 3, 32, 40, generator=g)
    y = (x + 0.1 * torch.randn(2, 3, 32, 40, generator=g)).clamp(0, 1)
    a = pm.ssim(x, y, data_range=1.0, size_average=True, win_size=11, win_sigma=1.5, K=(0.01, 0.03))
    torch.testing.assert_close(metrics.ssim_torch(x, y), a, atol=1e-5, rtol=0)


def test_ssim_loss_fallback_without_pytorch_msssim(monkeypatch):
    x, y = _rand_pair(5, noise=0.2)
    xt, yt = _nchw(x).float(), _nchw(y).float()
    with_pkg = losses.ssim(xt, yt)
    monkeypatch.setattr(losses, "_msssim_ssim", None)
    torch.testing.assert_close(losses.ssim(xt, yt), with_pkg, atol=1e-5, rtol=0)


def test_ssim_rejects_too_small_images():
    x = torch.rand(1, 3, 8, 32)
    with pytest.raises(ValueError):
        losses.ssim(x, x)
    with pytest.raises(ValueError):
        metrics.ssim(x, x)


def test_psnr_and_rmse_known_offsets():
    x = np.full((16, 16, 3), 0.4)
    assert metrics.mse(x + 0.1, x) == pytest.approx(0.01)
    assert metrics.psnr(x + 0.1, x) == pytest.approx(20.0)
    assert metrics.psnr(x + 0.01, x) == pytest.approx(40.0)
    assert metrics.rmse(x + 0.1, x) == pytest.approx(0.1 * math.sqrt(3))  # Euclidean in RGB
    y = x.copy()
    y[..., 0] += 0.3  # error only in red: per-pixel colour distance 0.3
    assert metrics.rmse(y, x) == pytest.approx(0.3)
    assert metrics.psnr(x, x) == math.inf


def test_metrics_numpy_torch_uint8_agree():
    x, y = _rand_pair(4, h=16, w=16)
    ev_np = metrics.evaluate(x, y)
    ev_t = metrics.evaluate(_nchw(x).float(), _nchw(y).float())
    assert set(ev_np) == {"psnr", "rmse", "ssim"}
    for k in ev_np:
        assert ev_np[k] == pytest.approx(ev_t[k], rel=1e-5)
    # Batches: average over images.
    xb, yb = np.stack([x, y]), np.stack([y, y])
    assert metrics.mse(xb, yb) == pytest.approx(metrics.mse(x, y) / 2)
    # uint8 is rescaled to [0, 1].
    q = (x * 255).round().astype(np.uint8)
    assert metrics.mse(q, q.astype(np.float64) / 255) == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(ValueError):
        metrics.mse(x, y[:8])


def test_masked_psnr_counts_the_masked_pixels_in_numpy_and_torch_alike():
    from lapig.lapig_core.common.psnr import masked_psnr

    x = np.full((2, 8, 8, 3), 0.4)
    y = x.copy()
    y[:, :4] += 0.1  # the top half off by 0.1 (20 dB), the bottom half exact
    top = np.zeros((8, 8), bool)
    top[:4] = True
    assert masked_psnr(y, x, top) == pytest.approx(20.0)
    per_image = np.stack([top, ~top])  # one mask per image: half the pixels off
    assert masked_psnr(y, x, per_image) == pytest.approx(20.0 + 10 * math.log10(2))
    assert masked_psnr(y, x, ~top) == math.inf and math.isnan(masked_psnr(y, x, np.zeros((8, 8), bool)))
    for mask in (top, per_image):  # the torch metric is the numpy one, on channel-first tensors too
        assert metrics.masked_psnr(torch.from_numpy(y).permute(0, 3, 1, 2), x, mask) == masked_psnr(y, x, mask)


# -- photometric losses ----------------------------------------------------------

def test_photometric_loss_combinations():
    g = torch.Generator().manual_seed(0)
    p, t = torch.rand(2, 3, 16, 16, generator=g), torch.rand(2, 3, 16, 16, generator=g)
    l1, l2, ls = losses.l1(p, t), losses.l2(p, t), losses.ssim_loss(p, t)
    torch.testing.assert_close(l1, (p - t).abs().mean())
    torch.testing.assert_close(l2, ((p - t) ** 2).mean())
    expect = {"l1": l1, "l1+ssim": l1 + ls, "l1+l2": l1 + l2, "l1+l2+ssim": l1 + l2 + ls}
    assert set(expect) == set(losses.LOSS_NAMES)
    for name, val in expect.items():
        torch.testing.assert_close(losses.photometric_loss(name, p, t), val)
    with pytest.raises(ValueError):
        losses.photometric_loss("l1+foo", p, t)


def test_photometric_loss_has_gradient():
    p = torch.rand(1, 3, 16, 16, requires_grad=True)
    losses.photometric_loss("l1+l2+ssim", p, torch.rand(1, 3, 16, 16)).backward()
    assert p.grad.abs().sum() > 0


# -- PSA losses ------------------------------------------------------------------

def test_projection_consistency_is_mse():
    a, b = torch.rand(2, 3, 8, 8), torch.rand(2, 3, 8, 8)
    torch.testing.assert_close(losses.projection_consistency_loss(a, b), ((a - b) ** 2).mean())


def test_compensation_saturation_loss():
    inside = torch.rand(2, 3, 8, 8, requires_grad=True)
    l0 = losses.compensation_saturation_loss(inside)
    l0.backward()
    assert float(l0.detach()) == 0 and inside.grad.abs().sum() == 0

    raw = torch.full((1, 3, 2, 2), 0.5)
    raw[0, 0, 0, 0], raw[0, 1, 1, 1] = 1.5, -0.5  # one above, one below
    raw.requires_grad_(True)
    loss = losses.compensation_saturation_loss(raw)
    assert loss.dim() == 0 and float(loss.detach()) == pytest.approx((0.25 + 0.25) / 12)
    loss.backward()
    assert raw.grad[0, 0, 0, 0] > 0  # descent pushes the high value down
    assert raw.grad[0, 1, 1, 1] < 0  # and the low value up
    assert raw.grad.abs().sum() == pytest.approx(float(raw.grad[0, 0, 0, 0] - raw.grad[0, 1, 1, 1]))

    m = losses.compensation_saturation_map(raw.detach())
    assert m.shape == (1, 1, 2, 2)
    assert float(m[0, 0, 0, 0]) == pytest.approx(0.25 / 3) and float(m[0, 0, 0, 1]) == 0
    torch.testing.assert_close(m.mean(), loss.detach())


def test_physical_saturation_loss_per_pixel_bounds():
    target = torch.tensor([0.1, 0.5, 0.9, 0.5]).view(1, 1, 2, 2).repeat(1, 3, 1, 1)
    i_min = torch.tensor([0.2, 0.0, 0.0, 0.4]).view(1, 1, 2, 2).repeat(1, 3, 1, 1)
    i_max = torch.tensor([1.0, 1.0, 0.7, 0.6]).view(1, 1, 2, 2).repeat(1, 3, 1, 1)
    target.requires_grad_(True)
    loss = losses.physical_saturation_loss(target, i_min, i_max)
    expect = (0.1 ** 2 + 0.2 ** 2) / 4  # pixel 0 below by 0.1, pixel 2 above by 0.2
    assert float(loss.detach()) == pytest.approx(expect)
    torch.testing.assert_close(loss, ((target.clamp(i_min, i_max) - target) ** 2).mean())
    loss.backward()
    g = target.grad[0, 0].flatten()
    assert g[0] < 0 and g[2] > 0 and g[1] == 0 and g[3] == 0

    m = losses.physical_saturation_map(target.detach(), i_min, i_max)
    assert m.shape == (1, 1, 2, 2)
    torch.testing.assert_close(m.mean(), loss.detach())
    # Scalar / default bounds.
    t2 = torch.tensor([-0.5, 1.5]).view(1, 1, 1, 2)
    assert float(losses.physical_saturation_loss(t2)) == pytest.approx(0.25)
    assert float(losses.physical_saturation_loss(t2, 0.0, 2.0)) == pytest.approx(0.125)


def test_sharpness_is_the_laplacian_energy_and_falls_with_blur():
    import cv2

    rng = np.random.default_rng(0)
    img = rng.random((48, 64, 3)).astype(np.float32)
    blurred = cv2.GaussianBlur(img, (0, 0), 1.5)
    assert metrics.sharpness(blurred) < 0.2 * metrics.sharpness(img)
    assert metrics.sharpness(np.full((16, 16, 3), 0.5)) == 0.0
    mask = np.zeros((48, 64), bool)
    mask[:, :32] = True
    assert metrics.sharpness(img, mask) > 0
    # sensor noise is high-frequency energy too; a 1-px blur first leaves the picture's own edges
    wave = np.repeat((0.5 + 0.4 * np.sin(np.arange(64) * 2 * np.pi / 24))[None, :, None], 48, 0).repeat(3, 2)
    noisy = wave + 0.02 * rng.standard_normal(wave.shape)
    assert metrics.sharpness(noisy) > 2 * metrics.sharpness(wave)
    assert abs(metrics.sharpness(noisy, sigma=1.0) / metrics.sharpness(wave, sigma=1.0) - 1) < 0.1


def _camera_loss(h=8, w=8, diag=(1.0, 1.0, 1.0), gamma_p=1.0, weight=None):
    from lapig.lapig_core.photometric.losses import CameraSpaceLoss

    m = torch.diag(torch.tensor(diag))[:, :, None, None].expand(3, 3, h, w).clone()
    weight = torch.ones(1, 1, h, w) if weight is None else weight
    return CameraSpaceLoss(m, gamma_p, weight)


def test_camera_space_loss_is_the_error_the_camera_sees():
    torch.manual_seed(0)
    pred, target = torch.rand(2, 3, 8, 8), torch.rand(2, 3, 8, 8)
    # identity M, linear projector: the l1 of the projector images (up to the +1 guarding an empty weight)
    loss = _camera_loss()(pred, target)
    assert loss == pytest.approx(float((pred - target).abs().sum() / (8 * 8 * 3 * 2 + 1)), rel=1e-5)
    assert float(_camera_loss()(target, target)) == 0.0
    # an error in a projector channel the camera does not see costs nothing
    shifted = target.clone()
    shifted[:, 1] += 0.3
    assert float(_camera_loss(diag=(1.0, 0.0, 1.0))(shifted, target)) == 0.0
    assert float(_camera_loss()(shifted, target)) > 0.05
    # pixels outside the weight (the projector cannot reach them) cost nothing, and get no gradient
    weight = torch.zeros(1, 1, 8, 8)
    weight[..., :, :4] = 1
    pred.requires_grad_(True)
    _camera_loss(weight=weight)(pred, target).backward()
    assert float(pred.grad[..., 4:].abs().sum()) == 0.0 and float(pred.grad[..., :4].abs().sum()) > 0
    # through the projector's transfer: a gamma_p > 1 makes dark projector errors cheap
    dark, bright = torch.full((1, 3, 8, 8), 0.1), torch.full((1, 3, 8, 8), 0.9)
    gamma = _camera_loss(gamma_p=2.2)
    assert float(gamma(dark + 0.05, dark)) < 0.2 * float(gamma(bright + 0.05, bright))


def test_camera_space_loss_crops_with_its_images_and_checks_shapes():
    from lapig.lapig_core.photometric.losses import CameraSpaceLoss

    torch.manual_seed(1)
    m = torch.rand(3, 3, 16, 12)
    weight = (torch.rand(1, 1, 16, 12) > 0.3).float()
    loss = CameraSpaceLoss(m, 1.7, weight)
    pred, target = torch.rand(2, 3, 16, 12), torch.rand(2, 3, 16, 12)
    rows, cols = slice(4, 12), slice(0, 8)
    alone = CameraSpaceLoss(m[..., rows, cols], 1.7, weight[..., rows, cols])
    assert float(loss.cropped(rows, cols)(pred[..., rows, cols], target[..., rows, cols])) == \
        pytest.approx(float(alone(pred[..., rows, cols], target[..., rows, cols])))
    assert loss.size == (16, 12)
    with pytest.raises(ValueError, match="3, 3, H, W"):
        CameraSpaceLoss(torch.rand(3, 16, 12), 1.0, weight)
    with pytest.raises(ValueError, match="same size"):
        CameraSpaceLoss(m, 1.0, torch.ones(1, 1, 8, 8))
