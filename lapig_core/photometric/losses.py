"""Training losses (torch, differentiable, NCHW images in [0, 1]).

Photometric losses of the training recipes, and the PSA (projector saturation
aware) losses:
  L_pc  projection_consistency_loss: simulated capture vs target (MSE)
  L_cs  compensation_saturation_loss: pre-clamp projector image outside [0,1]
  L_ps  physical_saturation_loss: target outside the reachable [I-, I+] range

SSIM uses pytorch-msssim's `ssim` (data_range=1, win 11, sigma 1.5, K=(0.01,
0.03)): separable Gaussian window, per channel, valid convolution (no padding),
mean of the map -- identical to metrics.ssim_torch. If the package is missing
we fall back to metrics.ssim_torch.
"""
import torch
from torch.nn import functional as F

from ..common.metrics import SSIM_K, SSIM_SIGMA, SSIM_WIN_SIZE, ssim_torch

try:
    from pytorch_msssim import ssim as _msssim_ssim
except ImportError:  # optional dependency; own implementation is equivalent
    _msssim_ssim = None

LOSS_NAMES = ("l1", "l1+ssim", "l1+l2", "l1+l2+ssim")


def l1(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    return F.l1_loss(pred, target)


def l2(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    return F.mse_loss(pred, target)


def ssim(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    h, w = pred.shape[-2:]
    if min(h, w) < SSIM_WIN_SIZE:
        # pytorch-msssim would silently skip the blur on short axes.
        raise ValueError(f"SSIM needs images at least {SSIM_WIN_SIZE}px, got {h}x{w}")
    if _msssim_ssim is not None:
        return _msssim_ssim(pred, target, data_range=1.0, size_average=True,
                            win_size=SSIM_WIN_SIZE, win_sigma=SSIM_SIGMA, K=SSIM_K)
    return ssim_torch(pred, target)


def ssim_loss(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    return 1.0 - ssim(pred, target)


_TERMS = {"l1": l1, "l2": l2, "ssim": ssim_loss}


def photometric_loss(name: str, pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Unit-weighted sum of the '+'-joined terms in `name`, e.g. 'l1+l2+ssim'."""
    terms = [t.strip() for t in name.lower().split("+")]
    unknown = [t for t in terms if t not in _TERMS]
    if unknown or not terms:
        raise ValueError(f"unknown loss {name!r}; use one of {LOSS_NAMES}")
    return sum(_TERMS[t](pred, target) for t in terms)


# -- camera-space loss of the compensation fine-tune -------------------------

class CameraSpaceLoss:
    """|M (f_p(P_hat) - f_p(P))| over the pixels the projector reaches: a compensation's error as the
    camera sees it, through the setup's fitted per-pixel colour mixing M and projector transfer
    f_p(P) = P ** gamma_p (photometric/classical).

    The paper's projector-space l1 weighs every projector value alike. Where the surface is dark, a
    capture-noise step maps to a large projector step, so that loss is ruled by pixels whose error the
    camera barely sees, and the bright texture the viewer sees best gets little weight. Measured
    through M the loss weighs each error as the viewer will see it (BENCHMARKS, issue 16: learned
    variants and the app's fine-tune).

    m: (3, 3, H, W), rows camera channels, columns projector channels; weight: (1, 1, H, W) in [0, 1].
    """

    def __init__(self, m: torch.Tensor, gamma_p: float, weight: torch.Tensor):
        if m.dim() != 4 or m.shape[:2] != (3, 3) or weight.shape[-2:] != m.shape[-2:]:
            raise ValueError(f"M must be (3, 3, H, W) and the weight (1, 1, H, W) of the same size; "
                             f"got {tuple(m.shape)} and {tuple(weight.shape)}")
        self.m, self.gamma_p, self.weight = m.float(), float(gamma_p), weight.float()

    @property
    def size(self) -> tuple:
        return tuple(self.m.shape[-2:])

    def to(self, device) -> "CameraSpaceLoss":
        return CameraSpaceLoss(self.m.to(device), self.gamma_p, self.weight.to(device))

    def cropped(self, rows: slice, cols: slice) -> "CameraSpaceLoss":
        """The same loss on a crop of the frame (the training crops)."""
        return CameraSpaceLoss(self.m[..., rows, cols], self.gamma_p, self.weight[..., rows, cols])

    def __call__(self, pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        # clamp_min: the gradient of P ** gamma_p is unbounded at 0 for gamma_p < 1
        diff = pred.clamp_min(1e-6) ** self.gamma_p - target.clamp_min(1e-6) ** self.gamma_p
        seen = (self.m[None] * diff[:, None]).sum(2)  # (B, 3, H, W): per pixel M @ diff
        w = self.weight.to(seen.dtype)
        return (seen.abs() * w).sum() / (w.sum() * 3 * len(pred) + 1.0)


# -- PSA losses ---------------------------------------------------------------

def projection_consistency_loss(simulated: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """L_pc: MSE between the simulated capture pi_hat(pi_dagger(target)) and target."""
    return F.mse_loss(simulated, target)


def compensation_saturation_map(raw: torch.Tensor) -> torch.Tensor:
    """Per-pixel L_cs, (B,1,H,W): squared distance of raw outside [0, 1].

    A squared hinge: zero inside the range, gradient 2*violation outside on
    either side, continuous at the bounds (no kink, unlike |.|), and on the
    same quadratic scale as the MSE terms it is summed with.
    """
    return (F.relu(raw - 1.0) ** 2 + F.relu(-raw) ** 2).mean(dim=1, keepdim=True)


def compensation_saturation_loss(raw: torch.Tensor) -> torch.Tensor:
    """L_cs on the pre-ReLU/clamp compensation output, mean over pixels and channels."""
    return compensation_saturation_map(raw).mean()


def _bound(v, like: torch.Tensor, default: float) -> torch.Tensor:
    return torch.as_tensor(default if v is None else v, dtype=like.dtype, device=like.device)


def clamped(x: torch.Tensor, i_min=None, i_max=None) -> torch.Tensor:
    """x within [i_min, i_max]: per-pixel tensors (I- / I+ captures) or scalars; None = 0 / 1.
    minimum/maximum (not clamp) so tensor bounds broadcast (PCNet's output clamp too)."""
    return torch.minimum(torch.maximum(x, _bound(i_min, x, 0.0)), _bound(i_max, x, 1.0))


def physical_saturation_map(target: torch.Tensor, i_min=None, i_max=None) -> torch.Tensor:
    """Per-pixel L_ps, (B,1,H,W): squared distance of target outside [i_min, i_max] (bounds as `clamped`'s;
    the gradient of the difference reaches `target` where it is out of range)."""
    return ((clamped(target, i_min, i_max) - target) ** 2).mean(dim=1, keepdim=True)


def physical_saturation_loss(target: torch.Tensor, i_min=None, i_max=None) -> torch.Tensor:
    """L_ps = MSE(clamp(target, i_min, i_max), target), mean over pixels and channels."""
    return physical_saturation_map(target, i_min, i_max).mean()
