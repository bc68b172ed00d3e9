"""PCNet: project-and-capture simulator pi_hat(x, s).

x is the projector input, s the surface image (capture under gray); the output
is the simulated camera capture, registered to projector space.
Images are (B, 3, H, W) in [0, 1], H and W divisible by 4.

Wiring (chosen so the count is exactly 1,231,767 parameters):
  surface branch on t0 = cat(s, x*s)  (x*s is a rough shading estimate):
      b1 = sc1(t0); b2 = sc2(ReLU(b1)); b3 = sc3(ReLU(b2)); b4 = sc4(ReLU(b3))
  backbone on x (branch outputs enter PRE-activation, i.e. the branch adds a
  signed, linear modulation and the backbone ReLU applies to the sum):
      h1 = ReLU(conv1(x) + b1)            32, H/2
      h2 = ReLU(conv2(h1) + b2)           64, H/4
      h3 = ReLU(conv3(h2) + b3)           128
      h4 = ReLU(conv4(h3) + b4)           256
      h5 = ReLU(conv5(h4) + skip2(h2))    128   (skip2: 3x3 64->128)
      h6 = ReLU(tconv1(h5) + skip1(h1))   64, H/2 (skip1: 1x1 32->64)
      h7 = ReLU(tconv2(h6))               32, H
      y  = ReLU(conv6(h7) + R(s))         R: 1x1, ReLU, 3x3, ReLU, 3x3, ReLU on s
  output = clamp(y, i_min, i_max) per pixel (default [0, 1]).
"""
import torch
from torch import nn
from torch.nn import functional as F

from ..losses import clamped
from .layout import into, out_of
from .net import Net


class PCNet(Net):
    ARCH_NAME = "PCNet"

    def __init__(self):
        super().__init__()
        # Backbone on x.
        self.conv1 = nn.Conv2d(3, 32, 3, 2, 1)
        self.add_trunk()
        # Surface branch on cat(s, x*s).
        self.sconv1 = nn.Conv2d(6, 32, 3, 2, 1)
        self.sconv2 = nn.Conv2d(32, 64, 3, 2, 1)
        self.sconv3 = nn.Conv2d(64, 128, 3, 1, 1)
        self.sconv4 = nn.Conv2d(128, 256, 3, 1, 1)
        # Skips.
        self.skip1 = nn.Conv2d(32, 64, 1, 1, 0)
        self.skip2 = nn.Conv2d(64, 128, 3, 1, 1)
        self.res_a = nn.Conv2d(3, 3, 1, 1, 0)
        self.res_b = nn.Conv2d(3, 3, 3, 1, 1)
        self.res_c = nn.Conv2d(3, 3, 3, 1, 1)
        self.init_weights()

    def forward(self, x: torch.Tensor, s: torch.Tensor, i_min=None, i_max=None) -> torch.Tensor:
        """Simulate the capture of projecting x onto surface s.

        i_min / i_max: per-pixel capture bounds (e.g. captures under black and
        white projection), broadcastable to (B, 3, H, W), or scalars; None
        means 0 / 1. The clamp keeps the simulation physically reachable.
        """
        x, s = into(x), into(s)  # channels-last on the CPU (archs/layout)
        s_once = s  # the residual path on s alone runs once for a batch of one surface, then broadcasts
        s = s.expand_as(x) if s.shape[0] == 1 else s  # one surface for a batch
        b1 = self.sconv1(torch.cat([s, x * s], dim=1))
        b2 = self.sconv2(F.relu(b1))
        b3 = self.sconv3(F.relu(b2))
        b4 = self.sconv4(F.relu(b3))

        h1 = F.relu(self.conv1(x) + b1)
        h2 = F.relu(self.conv2(h1) + b2)
        h3 = F.relu(self.conv3(h2) + b3)
        h4 = F.relu(self.conv4(h3) + b4)
        h5 = F.relu(self.conv5(h4) + self.skip2(h2))
        h6 = F.relu(self.tconv1(h5) + self.skip1(h1))
        h7 = F.relu(self.tconv2(h6))
        res = F.relu(self.res_c(F.relu(self.res_b(F.relu(self.res_a(s_once))))))
        y = F.relu(self.conv6(h7) + res)
        return out_of(clamped(y, i_min, i_max))
