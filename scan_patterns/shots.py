"""The `Shots` dataclass and the angle conventions of the head and sensor frames.

Head frame: x forward (the boresight), y left, z up. Azimuth is the angle about z from the
boresight, positive towards +y (counter-clockwise seen from above); elevation is the angle up
from the x-y plane. Livox's pattern files give `azimuth` (the same azimuth, degrees) and
`zenith` = 90 deg - elevation (90 = boresight), exactly as Livox's Gazebo plugin reads them:
direction = Rz(azimuth) Ry(zenith - 90 deg) (1, 0, 0).

The sensor frame is the same for a one-head sensor; a head with `yaw_deg` / `pitch_deg` is rotated
about the sensor's z (positive yaw = left) and then tilted (positive pitch = up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Shots:
    """Shots fired in the time window (t0_s, t1_s] (left-open, right-closed, like Livox's files).

    `dirs` are unit vectors in the head frame (from a pattern) or the sensor frame (from a sensor);
    shots are in time order within each head, heads one after another.
    """

    t_s: NDArray[np.float64]  # (N,) shot time, seconds
    dirs: NDArray[np.float32]  # (N, 3) unit direction
    head: NDArray[np.uint8]  # (N,) head index in the sensor
    line: NDArray[np.uint8]  # (N,) laser of the head that fired (Livox's `line`): shot k fires laser (k - 1) mod lasers
    sweep: NDArray[np.uint8]  # (N,) sweep index within the frame (0 outside `frame_shots`)
    t0_s: float
    t1_s: float

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def duration_s(self) -> float:
        return self.t1_s - self.t0_s


def make_shots(
    t_s: NDArray, dirs: NDArray, t0_s: float, t1_s: float, head: int = 0, line: NDArray | None = None
) -> Shots:
    """Shots of one head (sweep 0) from times and directions; `line` default all laser 0."""
    n = len(t_s)
    return Shots(
        np.asarray(t_s, np.float64),
        np.asarray(dirs, np.float32),
        np.full(n, head, np.uint8),
        np.zeros(n, np.uint8) if line is None else np.asarray(line, np.uint8),
        np.zeros(n, np.uint8),
        float(t0_s),
        float(t1_s),
    )


def concatenate(parts: list[Shots]) -> Shots:
    """Shots of several heads (or windows) in one, in the given order; the window spans them all."""
    return Shots(
        np.concatenate([p.t_s for p in parts]),
        np.concatenate([p.dirs for p in parts]),
        np.concatenate([p.head for p in parts]),
        np.concatenate([p.line for p in parts]),
        np.concatenate([p.sweep for p in parts]),
        min(p.t0_s for p in parts),
        max(p.t1_s for p in parts),
    )


def dirs_from_angles(azimuth_rad: NDArray, elevation_rad: NDArray, dtype=np.float64) -> NDArray:
    """(N, 3) unit vectors from azimuth and elevation (radians)."""
    az = np.asarray(azimuth_rad, dtype)
    el = np.asarray(elevation_rad, dtype)
    out = np.empty((len(az), 3), dtype)
    cos_el = np.cos(el)
    out[:, 0] = cos_el * np.cos(az)
    out[:, 1] = cos_el * np.sin(az)
    out[:, 2] = np.sin(el)
    return out


def angles_from_dirs(dirs: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(azimuth_rad, elevation_rad), float64, of unit vectors (N, 3)."""
    d = np.asarray(dirs, np.float64)
    return np.arctan2(d[:, 1], d[:, 0]), np.arcsin(np.clip(d[:, 2], -1.0, 1.0))


def dirs_from_livox(azimuth_deg: NDArray, zenith_deg: NDArray) -> NDArray[np.float64]:
    """Unit vectors from a Livox file's azimuth and zenith (degrees, zenith 90 = boresight)."""
    return dirs_from_angles(np.radians(azimuth_deg), np.radians(90.0 - np.asarray(zenith_deg, np.float64)))


def livox_angles(dirs: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(azimuth_deg, zenith_deg) of unit vectors, in the layout of Livox's files."""
    az, el = angles_from_dirs(dirs)
    return np.degrees(az), 90.0 - np.degrees(el)


def dirs_from_off_axis(rho_rad: NDArray, psi_rad: NDArray, dtype=np.float64) -> NDArray:
    """Unit vectors at off-axis angle `rho_rad` (may be negative: the opposite side) and angle `psi_rad`."""
    rho = np.asarray(rho_rad, dtype)
    psi = np.asarray(psi_rad, dtype)
    out = np.empty((len(rho), 3), dtype)
    sin_rho = np.sin(rho)
    out[:, 0] = np.cos(rho)
    out[:, 1] = sin_rho * np.cos(psi)
    out[:, 2] = sin_rho * np.sin(psi)
    return out


def angle_between_deg(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """Angle (degrees) between matching rows of two (N, 3) arrays of unit vectors."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    return np.degrees(2.0 * np.arctan2(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1)))


def rotate(vectors: NDArray, rotation: NDArray) -> NDArray:
    """vectors (N, 3) turned by a 3x3 rotation, in the vectors' dtype.

    Written out rather than `vectors @ rotation.T`: BLAS multithreads this tall, thin product and,
    on a loaded machine, spends 10-20x longer synchronising threads than computing.
    """
    rotation = rotation.astype(vectors.dtype)
    return vectors[:, :1] * rotation[:, 0] + vectors[:, 1:2] * rotation[:, 1] + vectors[:, 2:] * rotation[:, 2]


def head_rotation(yaw_deg: float, pitch_deg: float) -> NDArray[np.float64]:
    """3x3 matrix taking head-frame vectors to the sensor frame: yaw about z (left +), then pitch up."""
    yaw, pitch = np.radians(yaw_deg), np.radians(pitch_deg)
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]])  # +pitch lifts +x towards +z
    return rz @ ry
