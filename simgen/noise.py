"""The sensor's imperfections: range and angle noise, beam divergence, range limits, dropout, intensity.

Defaults are the Livox Mid-40 / Mid-100 datasheet: range precision 2 cm (1 sigma at 20 m), angular
accuracy < 0.1 deg, beam divergence 0.28 deg (vertical) x 0.03 deg (horizontal), detection range 90 m
at 10 % reflectivity, 130 m at 20 %, 260 m at 80 %. All randomness comes from the caller's
`numpy.random.Generator`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field


class NoiseConfig(BaseModel):
    """Noise model settings (scenario section `noise`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    range_sigma_m: float = Field(0.02, ge=0, le=1, description="Gaussian range noise, 1 sigma, metres.")
    angle_sigma_deg: float = Field(0.03, ge=0, le=1, description="Gaussian direction noise per axis, 1 sigma, degrees.")
    divergence_deg: tuple[float, float] = Field(
        (0.03, 0.28), description="Full beam divergence (horizontal, vertical), degrees."
    )
    subrays: int = Field(
        1, ge=1, le=16, description="Rays per shot spread over the beam footprint; the nearest return wins (1: off)."
    )
    min_range_m: float = Field(1.0, ge=0, le=50, description="Returns nearer than this are lost, metres.")
    max_range_at_10pct_m: float = Field(
        90.0, gt=0, le=1000, description="Detection range at 10 % reflectivity; it grows as sqrt(reflectivity), metres."
    )
    dropout: float = Field(0.0, ge=0, lt=1, description="Probability that a return is lost at random.")
    enabled: bool = Field(True, description="False: exact ranges and directions, no dropout (range limits still apply).")


def max_range_m(reflectivity: NDArray, cos_incidence: NDArray, config: NoiseConfig) -> NDArray[np.float64]:
    """Detection range for a Lambertian target: received power ~ reflectivity * cos(incidence) / range^2.

    sqrt(0.2 / 0.1) * 90 m = 127 m and sqrt(0.8 / 0.1) * 90 m = 255 m, as the datasheet's 130 m and 260 m.
    """
    effective = np.clip(reflectivity * cos_incidence, 1e-6, None)
    return config.max_range_at_10pct_m * np.sqrt(effective / 0.1)


def intensity(reflectivity: NDArray, cos_incidence: NDArray) -> NDArray[np.uint8]:
    """Livox-style calibrated reflectivity, 0-150 for diffuse targets (0-100 %), as uint8 0-255."""
    value = 150.0 * np.clip(reflectivity, 0, 1) * np.clip(cos_incidence, 0, 1)
    return np.clip(np.round(value), 0, 255).astype(np.uint8)


def jitter_directions(directions: NDArray, config: NoiseConfig, rng: np.random.Generator) -> NDArray[np.float64]:
    """Directions with angular noise (Gaussian, per axis); unit vectors in, unit vectors out."""
    if not config.enabled or config.angle_sigma_deg == 0:
        return directions
    noisy = directions + rng.normal(0.0, np.radians(config.angle_sigma_deg), directions.shape)
    return noisy / np.linalg.norm(noisy, axis=1, keepdims=True)


def subray_offsets_rad(config: NoiseConfig) -> NDArray[np.float64]:
    """(S, 2) fixed (horizontal, vertical) angular offsets covering the beam's elliptical footprint."""
    if config.subrays == 1:
        return np.zeros((1, 2))
    # Sunflower (Vogel) spiral over the unit disc, scaled to the half-divergences.
    k = np.arange(config.subrays) + 0.5
    radius = np.sqrt(k / config.subrays)
    angle = k * np.pi * (3 - np.sqrt(5))
    half = np.radians(np.asarray(config.divergence_deg)) / 2
    return np.stack([radius * np.cos(angle) * half[0], radius * np.sin(angle) * half[1]], axis=1)
