"""What a real camera saves: exposure, a non-linear response, sensor noise and 8-bit quantisation.

Blender renders linear radiance; this turns it into the 8-bit captures a real projector-camera
rig would produce, so the learned models meet the same non-linearities as on real data.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class CameraResponse:
    gamma: float = 2.2  # display-referred encoding like a camera's JPEG/PNG output
    toe: float = 0.01  # soft start so deep shadows are not crushed to a pure power law
    noise_std: float = 0.003  # sensor noise, in linear units, before the response
    exposure_stops: float = 0.0

    def __post_init__(self):
        if not self.gamma > 0:
            raise ValueError(f"camera response gamma must be positive, got {self.gamma}")
        if not self.toe > 0:
            raise ValueError(f"camera response toe must be positive, got {self.toe}")
        if self.noise_std < 0:
            raise ValueError(f"camera noise must not be negative, got {self.noise_std}")

    def curve(self, linear: np.ndarray) -> np.ndarray:
        """Linear exposure in [0,1] (clipped) -> encoded value in [0,1], monotonic, f(0)=0, f(1)=1."""
        x = np.clip(linear, 0.0, 1.0)
        g = 1.0 / self.gamma
        lo = self.toe ** g
        return (np.power(x + self.toe, g) - lo) / ((1.0 + self.toe) ** g - lo)

    def inverse(self, encoded: np.ndarray) -> np.ndarray:
        y = np.clip(encoded, 0.0, 1.0)
        g = 1.0 / self.gamma
        lo = self.toe ** g
        return np.power(y * ((1.0 + self.toe) ** g - lo) + lo, self.gamma) - self.toe

    def capture(self, radiance: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """Linear render -> 8-bit capture (uint8), exposure and noise included."""
        x = np.asarray(radiance, dtype=np.float32) * np.float32(2.0 ** self.exposure_stops)
        if self.noise_std > 0:
            rng = rng if rng is not None else np.random.default_rng(0)
            x = x + np.float32(self.noise_std) * rng.standard_normal(x.shape, dtype=np.float32)
        return np.round(self.curve(x) * 255.0).astype(np.uint8)

    def to_dict(self) -> dict:
        return asdict(self)


def auto_exposure_stops(white_radiance: np.ndarray, target: float = 0.85, percentile: float = 99.5,
                        mask: np.ndarray | None = None) -> float:
    """Exposure (stops) that puts the bright end of the white capture at `target` linear.

    Real operators set the camera so the projector's white does not clip; this does the same
    from the linear I+ render.
    """
    lum = np.asarray(white_radiance, dtype=np.float64).max(axis=-1)
    if mask is not None:
        lum = lum[mask]
    lum = lum[np.isfinite(lum)]
    if lum.size == 0 or np.percentile(lum, percentile) <= 0:
        raise ValueError("the projector's white lights nothing the camera sees: check that the "
                         "projector and the camera point at the object")
    return float(np.log2(target / np.percentile(lum, percentile)))


def clipped_fraction(capture_u8: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Share of pixels with a channel at 255 (saturated)."""
    sat = (np.asarray(capture_u8) >= 255).any(axis=-1)
    if mask is not None:
        sat = sat[mask]
    return float(sat.mean()) if sat.size else 0.0
