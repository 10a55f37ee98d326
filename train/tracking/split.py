"""The paper's split module: a detection that fuses two colliding players becomes two boxes.

A fused box sits near the average of the two players (Fig. 4): its centre near the midpoint of
their centres, its heading near the mean of their headings. After matching, each confirmed
trajectory left without a tracklet (an orphan) is checked against the matched confirmed
trajectories near it (``find_fusions``); a matched tracklet found to fuse a pair gives both
trajectories a box at t about its centre (``split_boxes``): players that run past each other keep
their predicted relative motion, players that meet or move together keep their offset. (The Kalman
prediction alone carries players who brake into each other through each other, and swaps them.)

Headings are box axes: a box turned by pi is the same box, so two yaws are averaged modulo pi
(angle doubling), and a mean of two nearly perpendicular axes carries no heading to test.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

_MIN_AXIS_AGREEMENT = 0.5  # below this mean resultant length the pair's mean axis is not tested


@dataclass(frozen=True)
class SplitConfig:
    max_pair_gap_m: float = 1.5  # trajectories farther apart at t-1 are never fused
    min_pair_gap_m: float = 0.25  # nor nearer: two bodies cannot be closer; such a pair is one player twice
    centre_tolerance_m: float = 0.4  # fused centre to the pair's midpoint, at most
    yaw_tolerance_rad: float = 0.5  # fused axis to the pair's mean axis, at most
    pass_m_per_frame: float = 0.4  # relative motion of a pair that runs past each other, at least


def axis_mean(
    yaw_a: NDArray[np.float64], yaw_b: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Mean box axis (radians, modulo pi) of two yaws and its agreement in [0, 1] (1: parallel)."""
    sin = np.sin(2 * yaw_a) + np.sin(2 * yaw_b)
    cos = np.cos(2 * yaw_a) + np.cos(2 * yaw_b)
    return 0.5 * np.arctan2(sin, cos), 0.5 * np.hypot(sin, cos)


def axis_gap(yaw_a: NDArray[np.float64], yaw_b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle in [0, pi/2] between two box axes."""
    return np.abs((yaw_a - yaw_b + np.pi / 2) % np.pi - np.pi / 2)


def find_fusions(
    fused: NDArray[np.float64],
    partners: NDArray[np.float64],
    orphans: NDArray[np.float64],
    orphan_was_matched: NDArray[np.bool_],
    still_fused: NDArray[np.bool_],
    config: SplitConfig,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Which matched tracklets fuse which orphan trajectories, all boxes at t-1.

    fused (M, 7): the matched tracklets' boxes; partners (M, 7): their trajectories' boxes;
    orphans (U, 7): the unmatched trajectories' boxes. A fusion starts only with an orphan that
    was matched at t-1 (``orphan_was_matched``, (U,)): a trajectory lost earlier is as likely a
    duplicate of its neighbour. Pairs split at t-1 (``still_fused``, (M, U)) stay fused while the
    fused box stays near their midpoint, whatever its heading and distance to the partner: without
    this hysteresis one noisy frame ends a split, the pair's offset halves, and a few such frames
    merge the two. Returns indices into fused and orphans, each used at most once, the pairs
    nearest their midpoints first.
    """
    mid = 0.5 * (partners[:, None, :3] + orphans[None, :, :3])  # (M, U, 3)
    off_mid = np.linalg.norm(fused[:, None, :3] - mid, axis=-1)
    off_partner = np.linalg.norm(fused[:, :3] - partners[:, :3], axis=-1)[:, None]
    gap = np.linalg.norm(partners[:, None, :2] - orphans[None, :, :2], axis=-1)
    mean_axis, agreement = axis_mean(partners[:, None, 6], orphans[None, :, 6])
    heading_ok = (agreement < _MIN_AXIS_AGREEMENT) | (
        axis_gap(fused[:, None, 6], mean_axis) <= config.yaw_tolerance_rad
    )
    starts = orphan_was_matched & (off_mid < off_partner) & heading_ok
    near = (gap >= config.min_pair_gap_m) & (gap <= config.max_pair_gap_m) & (off_mid <= config.centre_tolerance_m)
    ok = near & (starts | still_fused)
    fused_index, orphan_index = [], []
    for flat in np.argsort(np.where(ok, off_mid, np.inf), axis=None)[: np.count_nonzero(ok)]:
        m, u = np.unravel_index(flat, ok.shape)
        if m not in fused_index and u not in orphan_index:
            fused_index.append(m)
            orphan_index.append(u)
    return np.array(fused_index, dtype=np.intp), np.array(orphan_index, dtype=np.intp)


def split_boxes(
    fused: NDArray[np.float64], previous: NDArray[np.float64], predicted: NDArray[np.float64], config: SplitConfig
) -> NDArray[np.float64]:
    """The two players' boxes at t (F, 2, 7) for fused boxes at t (F, 7).

    previous (F, 2, 7): the pair's boxes at t-1; predicted (F, 2, 7): their Kalman predictions at t.
    The boxes are the predictions placed symmetrically about the fused box's centre, at the
    predicted offset between the two if it changes by more than ``pass_m_per_frame`` from t-1
    and keeps them ``min_pair_gap_m`` apart (players running past each other), else at their
    offset at t-1 (players moving together, or stopped by each other).
    """
    before = previous[:, 0, :3] - previous[:, 1, :3]
    after = predicted[:, 0, :3] - predicted[:, 1, :3]
    passing = np.linalg.norm(after - before, axis=1) > config.pass_m_per_frame
    passing &= np.linalg.norm(after[:, :2], axis=1) >= config.min_pair_gap_m  # bodies do not overlap
    half_gap = 0.5 * np.where(passing[:, None], after, before)
    boxes = predicted.copy()
    boxes[:, 0, :3] = fused[:, :3] + half_gap
    boxes[:, 1, :3] = fused[:, :3] - half_gap
    return boxes
