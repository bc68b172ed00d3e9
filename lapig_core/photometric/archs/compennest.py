"""CompenNeSt: compensation network pi_dagger(x, s).

x is the desired (camera-space, registered) image, s the surface image captured
under gray projection; the output is the projector input that should make the
capture look like x. Images are (B, 3, H, W) in [0, 1], H and W divisible by 4.

Wiring (our reading of the layer table, 805,559 parameters):
  * A siamese encoder with shared weights runs on x and on s:
        r1 = S1(z)                      3-3-3-3: 1x1, ReLU, 3x3, ReLU, 3x3 (full res)
        h1 = ReLU(conv1(z))             3->32, stride 2
        r2 = S2(h1)                     32-64-64: 1x1, ReLU, 3x3 (half res)
        h2 = ReLU(conv2(h1))            32->64, stride 2
        h3 = ReLU(conv3(h2))            64->128
  * The surface features are subtracted from the x features at three scales
    (r1, r2, h3), which removes the surface reflectance/texture the decoder
    must undo. No activation after the h3 difference, so it may be negative.
  * Decoder (x path only): conv4 -> conv5 -> tconv1 (+ r2, ReLU) -> tconv2 ->
    conv6 (+ r1) = raw; output = clamp(ReLU(raw), max=1).
The surface features depend only on s, so for a fixed setup they can be cached
(cache_surface); see _surface_features for when the cache is bypassed.
"""
import torch
from torch import nn
from torch.nn import functional as F

from .layout import into, out_of
from .net import Net


class CompenNeSt(Net):
    ARCH_NAME = "CompenNeSt"

    def __init__(self):
        super().__init__()
        # Siamese encoder (shared by x and s): these, then conv2 and conv3 of the trunk.
        self.s1_a = nn.Conv2d(3, 3, 1, 1, 0)
        self.s1_b = nn.Conv2d(3, 3, 3, 1, 1)
        self.s1_c = nn.Conv2d(3, 3, 3, 1, 1)
        self.conv1 = nn.Conv2d(3, 32, 3, 2, 1)
        self.s2_a = nn.Conv2d(32, 64, 1, 1, 0)
        self.s2_b = nn.Conv2d(64, 64, 3, 1, 1)
        self.add_trunk()  # the rest of the trunk, conv4 to conv6, is the decoder (x path only)
        self.init_weights()
        self.clear_surface_cache()

    # -- encoder -------------------------------------------------------------
    def encode(self, z: torch.Tensor, in_place: bool = False):
        """Shared encoder: returns (r1, r2, h3) for one input (in_place: see forward)."""
        relu = F.relu_ if in_place else F.relu
        z = into(z)  # channels-last on the CPU (archs/layout)
        r1 = self.s1_c(relu(self.s1_b(relu(self.s1_a(z)))))
        h1 = relu(self.conv1(z))
        r2 = self.s2_b(relu(self.s2_a(h1)))
        h2 = relu(self.conv2(h1))
        h3 = relu(self.conv3(h2))
        return r1, r2, h3

    # -- surface cache -------------------------------------------------------
    def _param_versions(self):
        # In-place updates (optimizer.step, load_state_dict) bump _version,
        # which tells us the cached features are stale.
        return tuple(p._version for p in self.parameters())

    def cache_surface(self, s: torch.Tensor) -> None:
        """Precompute the surface features for a fixed setup (inference speed-up), where the weights are: a
        surface still on the CPU beside weights on a GPU (SurfaceModels before its .to) is moved, not refused."""
        s = s.detach().to(self.conv1.weight.device)
        with torch.no_grad():
            feats = self.encode(s)
        self._cache = {"s": s, "feats": feats, "versions": self._param_versions()}

    def clear_surface_cache(self) -> None:
        self._cache = None

    def _surface_features(self, s, like: torch.Tensor):
        c = self._cache
        if s is None:
            if c is None:
                raise ValueError("no surface image given and none cached")
            s = c["s"]
        usable = (
            c is not None
            # Cached features are constants: using them while training would
            # drop the s-path gradient, so recompute then.
            and not (self.training and torch.is_grad_enabled())
            and (s is c["s"] or (s.shape == c["s"].shape and s.device == c["s"].device
                                 and torch.equal(s, c["s"])))
            and c["feats"][0].device == like.device and c["feats"][0].dtype == like.dtype
            and c["versions"] == self._param_versions()
        )
        if usable:
            return c["feats"]
        return self.encode(s.to(device=like.device, dtype=like.dtype))

    # -- forward -------------------------------------------------------------
    def forward(self, x: torch.Tensor, s: torch.Tensor = None, return_raw: bool = False):
        """Compensate x for surface s (s may be None if cached, batch 1 broadcasts).

        return_raw=True also returns the pre-ReLU/pre-clamp output, which the
        compensation saturation loss needs (the clamp has zero gradient outside).
        """
        r1s, r2s, h3s = self._surface_features(s, x)
        # Without a graph each activation, difference and sum is written over its input: the same
        # operations in the same order (bit-identical), but no fresh buffer per step. At 1920x1080 a
        # fresh buffer costs as much as the arithmetic on it (the kernel zeroes its pages): 0.95 s
        # against 1.45 s on 2 cores. (Only where x's batch sets the shape: s may broadcast over x.)
        in_place = not torch.is_grad_enabled() and r1s.shape[0] <= x.shape[0]
        relu = F.relu_ if in_place else F.relu
        sub = torch.Tensor.sub_ if in_place else torch.sub
        add = torch.Tensor.add_ if in_place else torch.add
        clamp = torch.Tensor.clamp_ if in_place else torch.clamp
        r1x, r2x, h3x = self.encode(x, in_place)
        h = sub(h3x, h3s)
        h = relu(self.conv4(h))
        h = relu(self.conv5(h))
        h = relu(add(self.tconv1(h), sub(r2x, r2s)))
        h = relu(self.tconv2(h))
        raw = add(self.conv6(h), sub(r1x, r1s))
        out = out_of(clamp(F.relu(raw) if return_raw else relu(raw), max=1.0))
        return (out, out_of(raw)) if return_raw else out
