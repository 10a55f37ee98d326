"""The sensor's imperfections: range and angle noise, beam divergence, range limits, dropout, intensity.

Defaults are the Livox Mid-40 / Mid-100 datasheet: range precision 2 cm (1 sigma at 20 m), angular
accuracy < 0.1 deg, beam divergence 0.28 deg (vertical) x 0.03 deg (horizontal), detection range 90 m
at 10 % reflectivity, 130 m at 20 %, 260 m at 80 %. All randomness comes from the caller's
`numpy.random.Generator`.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from simgen.scenario import NoiseConfig


class ReturnModel(NamedTuple):
    """The noise model's numbers as the compiled loop takes them (`return_model`)."""

    subrays: int  # rays per shot, consecutive
    min_range_m: float
    max_range_at_10pct_m: float  # see `max_range_m`
    dropout: float  # probability that a return in range is lost
    range_sigma_m: float
    angle_sigma_rad: float  # per axis across the beam


def return_model(noise: NoiseConfig) -> ReturnModel:
    """The scenario's noise as `noisy_returns` takes it: no dropout or noise when `noise.enabled` is off
    (beam divergence and range limits stay)."""
    on = noise.enabled
    return ReturnModel(
        noise.subrays,
        noise.min_range_m,
        noise.max_range_at_10pct_m,
        noise.dropout if on else 0.0,
        noise.range_sigma_m if on else 0.0,
        np.radians(noise.angle_sigma_deg) if on else 0.0,
    )


@numba.njit(cache=True)
def max_range_m(reflectivity: float, cos_incidence: float, max_range_at_10pct_m: float) -> float:
    """Detection range for a Lambertian target: received power ~ reflectivity * cos(incidence) / range^2.

    sqrt(0.2 / 0.1) * 90 m = 127 m and sqrt(0.8 / 0.1) * 90 m = 255 m, as the datasheet's 130 m and 260 m.
    """
    return max_range_at_10pct_m * np.sqrt(max(reflectivity * cos_incidence, 1e-6) / 0.1)


@numba.njit(cache=True)
def intensity(reflectivity: float, cos_incidence: float) -> int:
    """Livox-style calibrated reflectivity, 0-150 for diffuse targets (0-100 %), as 0-255."""
    value = 150.0 * min(max(reflectivity, 0.0), 1.0) * min(max(cos_incidence, 0.0), 1.0)
    return int(min(max(np.round(value), 0.0), 255.0))


@numba.njit(cache=True)
def noisy_returns(origins, directions, t_m, reflectivity, cos_incidence, model: ReturnModel, rng):
    """The returns of a sweep's shots (origins, unit directions (N, 3)), with noise.

    The hits (t_m, reflectivity, cos_incidence: (N * subrays,)) come `model.subrays` per shot,
    consecutive; a shot returns its nearest if that lies within [min_range_m, `max_range_m`], unless
    lost with probability `dropout`; its range then gets Gaussian noise (range_sigma_m) and its
    direction Gaussian angular noise per axis across the beam (angle_sigma_rad). Random numbers are
    drawn from rng point by point: dropout, range, then the two angles.

    Returns (hit index (P,), points (P, 3) float32 metres, intensity (P,) uint8, missed, dropped).
    """
    subrays, min_range_m, max_range_at_10pct_m, dropout, range_sigma_m, angle_sigma_rad = model
    shots = len(origins)
    ray = np.empty(shots, np.int64)
    points = np.empty((shots, 3), np.float32)
    value = np.empty(shots, np.uint8)
    count = missed = dropped = 0
    for shot in range(shots):
        k = shot * subrays
        for j in range(k + 1, k + subrays):
            if t_m[j] < t_m[k]:
                k = j
        t = t_m[k]
        if not (min_range_m <= t <= max_range_m(reflectivity[k], cos_incidence[k], max_range_at_10pct_m)):
            missed += 1
            continue
        if dropout > 0.0 and rng.random() < dropout:
            dropped += 1
            continue
        if range_sigma_m > 0.0:
            t += range_sigma_m * rng.standard_normal()
        dx, dy, dz = directions[shot, 0], directions[shot, 1], directions[shot, 2]
        if angle_sigma_rad > 0.0:
            # Across the beam: horizontal (d x z), then (d x horizontal); any unit pair for a vertical beam.
            horizontal = np.sqrt(dx * dx + dy * dy)
            ux, uy = (dy / horizontal, -dx / horizontal) if horizontal > 1e-12 else (1.0, 0.0)
            vx, vy, vz = -dz * uy, dz * ux, dx * uy - dy * ux
            a, b = angle_sigma_rad * rng.standard_normal(), angle_sigma_rad * rng.standard_normal()
            dx, dy, dz = dx + a * ux + b * vx, dy + a * uy + b * vy, dz + b * vz
            norm = np.sqrt(dx * dx + dy * dy + dz * dz)
            dx, dy, dz = dx / norm, dy / norm, dz / norm
        ray[count] = k
        points[count, 0] = origins[shot, 0] + t * dx
        points[count, 1] = origins[shot, 1] + t * dy
        points[count, 2] = origins[shot, 2] + t * dz
        value[count] = intensity(reflectivity[k], cos_incidence[k])
        count += 1
    return ray[:count], points[:count], value[:count], missed, dropped


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
