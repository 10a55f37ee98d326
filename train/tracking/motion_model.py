"""Constant-velocity Kalman filter on boxes, batched over tracks: AB3DMOT's model.

State per track, 10 numbers: ``(x, y, z, yaw, length, width, height, vx, vy, vz)``, metres, radians
and metres per frame (the step is one frame, as in AB3DMOT). A measurement is a box. A box turned
by pi is the same box, so the yaw innovation is taken modulo pi, in [-pi/2, pi/2): this is what
AB3DMOT's orientation correction does, written as one wrap.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import NDArray

STATE_DIM = 10
MEASURE_DIM = 7
_BOX_TO_STATE = np.array([0, 1, 2, 6, 3, 4, 5])  # box (x, y, z, l, w, h, yaw) -> state order (x, y, z, yaw, l, w, h)
_STATE_TO_BOX = np.array([0, 1, 2, 4, 5, 6, 3])
_YAW = 3

_TRANSITION = np.eye(STATE_DIM)
_TRANSITION[0:3, 7:10] = np.eye(3)  # position += velocity
_MEASURE_EYE = np.eye(MEASURE_DIM)


@dataclass(frozen=True)
class KalmanConfig:
    """Variances in state units (m^2, rad^2, (m/frame)^2); AB3DMOT's values by default."""

    initial_variance: float = 10.0
    initial_velocity_variance: float = 10_000.0
    process_variance: float = 1.0
    process_velocity_variance: float = 0.01
    measurement_variance: float = 1.0

    @cached_property
    def initial_covariance(self) -> NDArray[np.float64]:
        """(10, 10) diagonal, read-only."""
        return _read_only(np.diag([self.initial_variance] * MEASURE_DIM + [self.initial_velocity_variance] * 3))

    @cached_property
    def process_noise(self) -> NDArray[np.float64]:
        """(10, 10) diagonal, read-only."""
        return _read_only(np.diag([self.process_variance] * MEASURE_DIM + [self.process_velocity_variance] * 3))


def _read_only(array: NDArray[np.float64]) -> NDArray[np.float64]:
    array.flags.writeable = False
    return array


# For players seen at 10 Hz: boxes good to about 0.1 m (0.1 rad), accelerations up to about 5 m/s^2
# (0.05 m/frame per frame). AB3DMOT's values suit cars and metre-level detections: with them the
# velocity lags a player's braking by seconds.
PLAYER_KALMAN = KalmanConfig(
    initial_variance=0.01,
    process_variance=0.001,
    process_velocity_variance=0.003,
    measurement_variance=0.01,
)
# A tracker config's `motion_model`: the variances by name.
MOTION_MODELS = {"kalman_player": PLAYER_KALMAN, "kalman_ab3dmot": KalmanConfig()}
MotionModel = Literal["kalman_player", "kalman_ab3dmot"]


@dataclass
class KalmanState:
    """Means (K, 10) and covariances (K, 10, 10) of K tracks."""

    mean: NDArray[np.float64]
    covariance: NDArray[np.float64]


def init_state(boxes: NDArray[np.float64], config: KalmanConfig) -> KalmanState:
    """Tracks at rest at boxes (K, 7)."""
    mean = np.zeros((len(boxes), STATE_DIM))
    mean[:, :MEASURE_DIM] = boxes[:, _BOX_TO_STATE]
    return KalmanState(mean, np.repeat(config.initial_covariance[None], len(boxes), axis=0))


def predict(state: KalmanState, config: KalmanConfig) -> KalmanState:
    """The state one frame later."""
    mean = state.mean @ _TRANSITION.T
    covariance = _TRANSITION @ state.covariance @ _TRANSITION.T + config.process_noise
    return KalmanState(mean, covariance)


def update(state: KalmanState, boxes: NDArray[np.float64], config: KalmanConfig) -> KalmanState:
    """The state after measuring boxes (K, 7), one per track."""
    innovation = boxes[:, _BOX_TO_STATE] - state.mean[:, :MEASURE_DIM]
    innovation[:, _YAW] = (innovation[:, _YAW] + np.pi / 2) % np.pi - np.pi / 2
    cross = state.covariance[:, :, :MEASURE_DIM]  # P H^T, (K, 10, 7)
    system = cross[:, :MEASURE_DIM] + config.measurement_variance * _MEASURE_EYE  # H P H^T + R
    gain = np.linalg.solve(system, cross.transpose(0, 2, 1)).transpose(0, 2, 1)  # S is symmetric
    mean = state.mean + np.einsum("kij,kj->ki", gain, innovation)
    mean[:, _YAW] = (mean[:, _YAW] + np.pi) % (2 * np.pi) - np.pi
    covariance = state.covariance - gain @ cross.transpose(0, 2, 1)
    return KalmanState(mean, covariance)


def state_boxes(state: KalmanState) -> NDArray[np.float64]:
    """(K, 7) boxes of the state means."""
    return state.mean[:, _STATE_TO_BOX]
