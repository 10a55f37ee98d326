"""Standing players on a grid over the pitch, rendered by the real renderer: points per player per frame at
every cell, per sensor of a rig.

Each cell's player stands alone: the players rendered together in one frame are a *batch* chosen so that,
seen from every sensor, their azimuth intervals (a vertical cylinder of `BODY_RADIUS_M` round each) do not
overlap, and no ray can meet two of them. Every batch is rendered once per heading; all batches and headings
are the frames of one motion clip of standing players (a frame per (batch, heading), unused humanoids parked
under the ground) cast as snapshots at the frames' own times, so one `World` serves the whole grid. The scan
pattern's rays are made once for `PATTERN_FRAMES` consecutive frames and reused round robin, so that a cell's
headings meet different parts of the pattern.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from simgen.body.standing import standing_keypoints
from simgen.errors import UserError
from simgen.motion.clip import MotionClip
from simgen.render.frame import render_frame
from simgen.render.world import World
from simgen.scan.sensor import Sensor, scenario_sensors
from simgen.scan.sensor_rig import frame_rays
from simgen.scenario import BYTES_PER_SHOT, Scenario
from simgen.scene.static import build_static_scene
from simgen.vocab import PITCH_LENGTH_M, PITCH_WIDTH_M

BODY_RADIUS_M = 0.7  # a standing player, arms and feet included, fits in a vertical cylinder this wide, with margin
AZIMUTH_BIN_RAD = 0.004  # resolution of the batching's azimuth occupancy (intervals are rounded outwards)
PATTERN_FRAMES = 16  # scan-pattern frames made once and cycled through (fewer where their rays would not fit)
PATTERN_BYTES = 256 << 20  # memory the cycled frames' rays may take
PARKED_Z_M = -50.0  # unused humanoids of a frame stand here, under the ground no ray goes past
MIN_STEP_M, MAX_STEP_M = 0.25, 34.0  # grid steps allowed (0.25 m: 114,240 cells)
MAX_HEADINGS = 16
MAX_PLAYERS = 120_000  # standing players (cells x headings) of one grid: a 1 m grid in 16 headings, 0.25 m in one
GRID_STREAM = 39  # SeedSequence key of the grid's noise, apart from any dataset's clips


@dataclass(frozen=True)
class PitchGrid:
    """Cells of `step_m` over the pitch (the last row and column may fall short of the lines): centres, metres."""

    step_m: float
    x_m: NDArray[np.float64]  # (X,)
    y_m: NDArray[np.float64]  # (Y,)

    @property
    def centres_m(self) -> NDArray[np.float64]:
        """(X * Y, 2) cell centres, x major (cell i = ix * Y + iy)."""
        x, y = np.meshgrid(self.x_m, self.y_m, indexing="ij")
        return np.stack([x.reshape(-1), y.reshape(-1)], axis=1)


@dataclass(frozen=True)
class GridCoverage:
    """Points on a standing player per frame at every cell, per sensor, for each heading."""

    grid: PitchGrid
    headings_deg: NDArray[np.float64]  # (K,)
    sensor_names: tuple[str, ...]  # (S,)
    points: NDArray[np.int32]  # (C, K, S) points of one frame on the cell's player, by heading and sensor
    frames: int  # frames rendered

    @property
    def rig_mean(self) -> NDArray[np.float64]:
        """(C,) points per frame of the whole rig, mean over headings."""
        return self.points.sum(axis=2).mean(axis=1)

    def sensor_mean(self, sensor: int) -> NDArray[np.float64]:
        """(C,) points per frame of one sensor, mean over headings."""
        return self.points[:, :, sensor].mean(axis=1)


def pitch_grid(step_m: float) -> PitchGrid:
    """The grid of `step_m` metres over the pitch; refuses steps outside [MIN_STEP_M, MAX_STEP_M]."""
    if not (math.isfinite(step_m) and MIN_STEP_M <= step_m <= MAX_STEP_M):
        raise UserError(f"--step {step_m:g} m: a grid step must lie in [{MIN_STEP_M:g}, {MAX_STEP_M:g}] m")

    def centres(length: float) -> NDArray[np.float64]:
        return -length / 2 + step_m / 2 + step_m * np.arange(max(1, math.floor(length / step_m + 1e-9)))

    return PitchGrid(step_m, centres(PITCH_LENGTH_M), centres(PITCH_WIDTH_M))


def checked_grid(step_m: float, headings: int) -> PitchGrid:
    """The grid, after refusing a step, a number of headings or their product (the players to render, which
    bound memory and time) outside the limits."""
    grid = pitch_grid(step_m)
    if not 1 <= headings <= MAX_HEADINGS:
        raise UserError(f"--headings {headings}: must lie in [1, {MAX_HEADINGS}]")
    players = len(grid.x_m) * len(grid.y_m) * headings
    if players > MAX_PLAYERS:
        raise UserError(f"--step {step_m:g} m in {headings} headings: {players:,} standing players to render, more "
                        f"than {MAX_PLAYERS:,} (raise --step or lower --headings)")
    return grid


def azimuth_bins(centres_m: NDArray, sensors_xy_m: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64], int]:
    """Each cell's azimuth interval seen from each sensor, as bins of AZIMUTH_BIN_RAD: first and last (C, S)
    (the last may exceed the bin count: it wraps round), and the bin count."""
    bins = math.ceil(2 * math.pi / AZIMUTH_BIN_RAD)
    offset = centres_m[:, None, :] - sensors_xy_m[None, :, :]
    distance = np.hypot(offset[..., 0], offset[..., 1])
    azimuth = np.arctan2(offset[..., 1], offset[..., 0]) % (2 * np.pi)
    half = np.where(distance > BODY_RADIUS_M, np.arcsin(np.minimum(BODY_RADIUS_M / np.maximum(distance, 1e-9), 1)),
                    np.pi)
    first = np.floor((azimuth - half) / AZIMUTH_BIN_RAD).astype(np.int64) % bins
    last = first + np.ceil(2 * half / AZIMUTH_BIN_RAD).astype(np.int64) + 1
    return first, np.minimum(last, first + bins - 1), bins


@numba.njit(cache=True)
def _first_fit(first, last, bins):
    """Batch of each cell (C,): the first batch where none of its azimuth bins is taken from any sensor."""
    cells, sensors = first.shape
    capacity = 64
    taken = np.zeros((capacity, sensors, bins), np.bool_)
    batch = np.empty(cells, np.int64)
    used = 0
    for c in range(cells):
        b = 0
        while True:
            if b == used:
                if used == capacity:
                    grown = np.zeros((2 * capacity, sensors, bins), np.bool_)
                    grown[:capacity] = taken
                    taken, capacity = grown, 2 * capacity
                used += 1
                break
            free = True
            for s in range(sensors):
                for k in range(first[c, s], last[c, s] + 1):
                    if taken[b, s, k % bins]:
                        free = False
                        break
                if not free:
                    break
            if free:
                break
            b += 1
        for s in range(sensors):
            for k in range(first[c, s], last[c, s] + 1):
                taken[b, s, k % bins] = True
        batch[c] = b
    return batch


def batches(centres_m: NDArray, sensors: tuple[Sensor, ...]) -> NDArray[np.int64]:
    """(C,) batch of each cell: cells of one batch never share a ray of any sensor."""
    sensors_xy = np.array([s.origin_m[:2] for s in sensors])
    return _first_fit(*azimuth_bins(centres_m, sensors_xy))


def standing_clip(centres_m: NDArray, batch: NDArray, headings_rad: NDArray) -> tuple[MotionClip, NDArray]:
    """A clip of standing players, a frame (1 s apart) per (batch, heading), batch major, and a copy of the last
    (a clip spans two frames at least); and the humanoid that stands for each cell (C,). Humanoids a frame does
    not use stand under the ground."""
    num_batches = int(batch.max()) + 1
    order = np.argsort(batch, kind="stable")
    size = np.bincount(batch, minlength=num_batches)
    slot = np.empty(len(batch), np.int64)
    slot[order] = np.arange(len(batch)) - np.repeat(np.cumsum(size) - size, size)
    humanoids, headings = int(size.max()), len(headings_rad)
    frames = num_batches * headings + 1
    keypoints = np.empty((frames, humanoids, 12, 3), np.float32)
    parked = standing_keypoints(np.zeros((humanoids, 2)), np.zeros(humanoids))
    parked[..., 2] += PARKED_Z_M
    for k, heading in enumerate(headings_rad):
        posed = standing_keypoints(centres_m, np.full(len(centres_m), heading)).astype(np.float32)
        frame_keypoints = np.broadcast_to(parked.astype(np.float32), (num_batches, humanoids, 12, 3)).copy()
        frame_keypoints[batch, slot] = posed
        keypoints[np.arange(num_batches) * headings + k] = frame_keypoints
    keypoints[-1] = keypoints[-2]
    clip = MotionClip(
        time_s=np.arange(frames, dtype=np.float64),
        keypoints_m=keypoints,
        ball_m=np.tile(np.float32([0.0, 0.0, PARKED_Z_M]), (frames, 1)),
        engine_position_m=np.full((frames, humanoids, 3), np.nan, np.float32),
        track_id=np.arange(humanoids, dtype=np.int32),
        team=np.array(["left"] * humanoids),
        role=np.array(["CM"] * humanoids),
        jersey=np.full(humanoids, -1, np.int16),
        capture_hz=1,
    )
    return clip, slot


def grid_coverage(
    scenario: Scenario, step_m: float, headings_deg: NDArray, progress: Callable[[int, int], None] | None = None
) -> GridCoverage:
    """Render a standing player at every cell of the grid, once per heading, with the scenario's sensors, scan,
    noise and static scene; `progress(done, total)` is told of each frame."""
    headings_deg = np.asarray(headings_deg, np.float64)
    grid = checked_grid(step_m, len(headings_deg))
    sensors = scenario_sensors(scenario)
    centres = grid.centres_m
    batch = batches(centres, sensors)
    clip, slot = standing_clip(centres, batch, np.radians(headings_deg))
    scene = scenario.scene
    world = World(clip, build_static_scene(scene.goals, scene.surroundings, scene.net_transmission))
    first = frame_rays(scenario.scan, sensors, 0, 0.0)
    fit = PATTERN_BYTES // max(1, len(first.time_s) * BYTES_PER_SHOT)
    patterns = [first] + [frame_rays(scenario.scan, sensors, k, 0.0) for k in range(1, min(PATTERN_FRAMES, fit))]
    humanoids, num_sensors, headings = clip.num_humanoids, len(sensors), len(headings_deg)
    frames = clip.num_frames - 1
    per_frame = np.empty((frames, humanoids, num_sensors), np.int32)
    for frame in range(frames):
        rng = np.random.default_rng(np.random.SeedSequence([scenario.seed, GRID_STREAM, frame]))
        scan = render_frame(world, patterns[frame % len(patterns)], 0.0, scenario.noise, rng, float(frame))
        on_player = (scan.instance_id >= 0) & (scan.instance_id < humanoids)
        key = scan.instance_id[on_player].astype(np.int64) * num_sensors + scan.sensor[on_player]
        per_frame[frame] = np.bincount(key, minlength=humanoids * num_sensors).reshape(humanoids, num_sensors)
        if progress is not None:
            progress(frame + 1, frames)
    frame_of = batch[:, None] * headings + np.arange(headings)[None, :]  # (C, K)
    points = per_frame[frame_of, slot[:, None]]
    return GridCoverage(grid, headings_deg, tuple(s.name for s in sensors), points, frames)
