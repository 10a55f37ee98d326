"""Synthetic football clips for the trackers: ground-truth players and the tracklets made from them.

Players run on the pitch (origin at the centre spot, z up) between random goals at their own pace,
up to ``max_speed_mps``, with bounded acceleration and turning; their box heading follows their
velocity. Scripted encounters are added: two nearby players run to marks 4 m on either side of the
spot between them and start together from there; in a *meeting* they run to the spot and stand
there (centres 0.4 m apart, boxes overlapping) before parting, in a *crossing* they run on past
each other with 0.3 m between their paths.

Tracklets are the ground-truth boxes at t-2, t-1 and t (the first frames repeat frame 0), with,
optionally, Gaussian noise, runs of missed detections, false tracklets (anywhere, duplicates
straying from a detected player, or a flood of near-duplicates a set distance from each), and *fused* tracklets for
players closer than ``fuse_distance_m``: one tracklet whose boxes are the average of the two players' (centre, size and
box axis), as in the paper's Fig. 4. Everything random comes from the numpy Generator passed in.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from train.tracking.split import axis_mean
from train.tracking.types import TRACKLET_LEN, GroundTruthFrame, Tracklets

_ARRIVED_M = 0.3  # a free player this close to his goal picks a new one
_MOVING_MPS = 0.5  # slower players keep their heading
_MEETING_GAP_M = 0.4  # centre distance of two players standing together
_CROSSING_GAP_M = 0.3  # distance between the paths of two crossing players
_RUN_UP_M = 4.0  # encounters start from marks this far from the spot
_TO_MARK_MPS = 5.0  # pace to the marks


@dataclass(frozen=True)
class PlayersConfig:
    n_players: int = 22
    n_frames: int = 300
    frame_rate_hz: float = 10.0
    pitch_m: tuple[float, float] = (105.0, 68.0)
    max_speed_mps: float = 8.0
    max_accel_mps2: float = 4.0
    max_turn_rad_s: float = 2 * np.pi
    size_m: tuple[float, float, float] = (0.6, 0.8, 1.8)  # length (along the heading), width, height
    size_sigma_m: float = 0.05
    meetings: int = 3
    crossings: int = 3
    stand_frames: tuple[int, int] = (5, 20)  # how long a meeting lasts, drawn in this range


@dataclass(frozen=True)
class Encounter:
    kind: str  # "meeting" or "crossing"
    players: tuple[int, int]
    start_frame: int


@dataclass(frozen=True)
class PlayersClip:
    boxes: NDArray[np.float64]  # (T, P, 7)
    ids: NDArray[np.int64]  # (P,)
    encounters: tuple[Encounter, ...]

    def frames(self) -> list[GroundTruthFrame]:
        return [GroundTruthFrame(b, self.ids) for b in self.boxes]


@dataclass(frozen=True)
class DetectionNoise:
    centre_sigma_m: float = 0.0  # per axis, on each of a tracklet's three boxes
    yaw_sigma_rad: float = 0.0
    size_sigma_m: float = 0.0
    miss_prob: float = 0.0  # chance per frame that a detected player starts being missed
    miss_mean_frames: float = 1.0  # mean length of a run of missed frames
    fuse_distance_m: float = 0.0  # closer players at t are detected as one fused tracklet
    false_per_frame: float = 0.0  # mean number of false tracklets per frame, anywhere on the pitch
    duplicate_prob: float = 0.0  # chance per frame that a detected player gets a second, false tracklet
    duplicate_sigma_m: float = 0.3  # per axis: how far a duplicate strays from the player
    near_duplicates: float = 0.0  # mean number (Poisson) of near-duplicates per detected tracklet per frame
    near_distance_m: tuple[float, float] = (0.3, 1.0)  # their centres' BEV distance from it, uniform
    score_range: tuple[float, float] = (0.6, 1.0)
    false_score_range: tuple[float, float] = (0.1, 0.6)


# A sparse-LiDAR detector as the trackers' tests and benchmark assume it: boxes good to 8 cm and
# 0.1 rad, 3 % of players start a run of misses (2 frames on average) each frame, players closer
# than 0.8 m fused, 0.3 false tracklets a frame anywhere and 2 % of detections duplicated nearby.
NOISY_DETECTOR = DetectionNoise(
    centre_sigma_m=0.08,
    yaw_sigma_rad=0.1,
    size_sigma_m=0.03,
    miss_prob=0.03,
    miss_mean_frames=2.0,
    fuse_distance_m=0.8,
    false_per_frame=0.3,
    duplicate_prob=0.02,
)

# The audit's medium-noise tracklets made from a paper_x1 clip's ground truth (issue 13): boxes good
# to 8 cm, 5 cm in size and 0.2 rad, 5 % of players missed in runs of 2 frames (0.026 start a run
# each frame: 0.026 * 2 / (1 + 0.026 * 2) = 5 %), players closer than 0.8 m fused, 1 false
# tracklet a frame anywhere.
MEDIUM_NOISE = replace(
    NOISY_DETECTOR, yaw_sigma_rad=0.2, size_sigma_m=0.05, miss_prob=0.026, false_per_frame=1.0, duplicate_prob=0.0
)

# A weak detector's raw output as the study's 300-iteration late model gives it before filtering:
# the medium noise plus about 3 near-duplicates a player 0.3-1 m away (its 0.5 m output grid makes
# them), scored like the weaker true tracklets; about 85 tracklets a frame, 75 % false.
FLOOD = replace(MEDIUM_NOISE, near_duplicates=3.0, score_range=(0.35, 1.0), false_score_range=(0.1, 0.5))


class _Players:
    """Kinematic state of P players, advanced a frame at a time."""

    def __init__(self, config: PlayersConfig, rng: np.random.Generator) -> None:
        self.config, self.rng = config, rng
        self.half = 0.5 * np.asarray(config.pitch_m)
        n = config.n_players
        self.pos = rng.uniform(-self.half, self.half, (n, 2))
        self.vel = np.zeros((n, 2))
        self.yaw = rng.uniform(-np.pi, np.pi, n)
        self.goal = self.pos.copy()
        self.cruise = np.zeros(n)
        self.hold_until = np.full(n, -1)  # frame until which a player waits at his goal
        self.busy_until = np.full(n, -1)  # frame until which an encounter drives him
        self.next_goal = np.full((n, 2), np.nan)  # where a waiting player runs once released
        self.next_cruise = np.zeros(n)

    def free_goals(self, frame: int) -> None:
        free = (self.busy_until < frame) & (np.linalg.norm(self.goal - self.pos, axis=1) < _ARRIVED_M)
        n = np.count_nonzero(free)
        self.goal[free] = self.rng.uniform(-self.half, self.half, (n, 2))
        self.cruise[free] = self.rng.uniform(1.0, self.config.max_speed_mps, n)

    def encounter(self, i: int, j: int, frame: int, kind: str) -> None:
        """Both run to marks on either side of the spot between them and wait for each other; then,
        at one pace, in a meeting they run to the spot and stand there together until released, in
        a crossing they run on past each other to the other side's mark."""
        cfg = self.config
        spot = 0.5 * (self.pos[i] + self.pos[j])
        away = (self.pos[i] - self.pos[j]) / max(np.linalg.norm(self.pos[i] - self.pos[j]), 1e-9)
        side = np.array([-away[1], away[0]])
        reach_s = np.linalg.norm(self.pos[i] - spot) / _TO_MARK_MPS + 4.0  # ample: both wait at their marks
        start = frame + int(reach_s * cfg.frame_rate_hz)
        cruise = self.rng.uniform(3.0, cfg.max_speed_mps)
        for player, sign in ((i, 1.0), (j, -1.0)):
            mark = spot + sign * away * _RUN_UP_M
            if kind == "meeting":
                after = spot + sign * away * 0.5 * _MEETING_GAP_M
                stand_s = self.rng.integers(*cfg.stand_frames, endpoint=True) / cfg.frame_rate_hz
                busy_s = _RUN_UP_M / cruise + 2.0 + stand_s
            else:
                mark = mark + sign * side * 0.5 * _CROSSING_GAP_M
                after = mark - sign * away * 2 * _RUN_UP_M
                busy_s = 2 * _RUN_UP_M / cruise + 2.0
            self.goal[player] = np.clip(mark, -self.half, self.half)
            self.cruise[player] = _TO_MARK_MPS
            self.next_goal[player] = np.clip(after, -self.half, self.half)
            self.next_cruise[player] = cruise
            self.hold_until[player] = start
            self.busy_until[player] = start + int(busy_s * cfg.frame_rate_hz)

    def advance(self, frame: int) -> None:
        cfg, dt = self.config, 1.0 / self.config.frame_rate_hz
        to_goal = self.goal - self.pos
        dist = np.linalg.norm(to_goal, axis=1)
        # Brake to stop at the goal, planned at half the acceleration so that the limit never overshoots.
        speed = np.minimum(self.cruise, np.minimum(np.sqrt(cfg.max_accel_mps2 * dist), dist / dt))
        want = to_goal / np.maximum(dist, 1e-9)[:, None] * speed[:, None]
        change = want - self.vel
        norm = np.linalg.norm(change, axis=1)
        self.vel += change * np.minimum(1.0, cfg.max_accel_mps2 * dt / np.maximum(norm, 1e-9))[:, None]
        self.pos = np.clip(self.pos + self.vel * dt, -self.half, self.half)
        moving = np.linalg.norm(self.vel, axis=1) > _MOVING_MPS
        heading = np.arctan2(self.vel[:, 1], self.vel[:, 0])
        turn = np.clip(
            (heading - self.yaw + np.pi) % (2 * np.pi) - np.pi, -cfg.max_turn_rad_s * dt, cfg.max_turn_rad_s * dt
        )
        self.yaw = np.where(moving, (self.yaw + turn + np.pi) % (2 * np.pi) - np.pi, self.yaw)
        released = self.hold_until == frame
        self.goal[released] = np.where(np.isnan(self.next_goal[released]), self.pos[released], self.next_goal[released])
        self.cruise[released] = self.next_cruise[released]
        self.next_goal[released] = np.nan  # no next goal: free, a new goal next frame

    def nearest_free(self, i: int, frame: int) -> int:
        dist = np.linalg.norm(self.pos - self.pos[i], axis=1)
        dist[(self.busy_until >= frame) | (np.arange(len(dist)) == i)] = np.inf
        return int(np.argmin(dist))


def simulate_players(config: PlayersConfig, rng: np.random.Generator) -> PlayersClip:
    """A clip of ground-truth player boxes, scripted encounters spread evenly over it."""
    players = _Players(config, rng)
    kinds = ["meeting"] * config.meetings + ["crossing"] * config.crossings
    rng.shuffle(kinds)
    starts = np.linspace(0, config.n_frames, len(kinds) + 2)[1:-1].astype(int)
    schedule = dict(zip(starts.tolist(), kinds))
    sizes = np.asarray(config.size_m) + rng.normal(0.0, config.size_sigma_m, (config.n_players, 3))
    boxes = np.zeros((config.n_frames, config.n_players, 7))
    encounters = []
    for frame in range(config.n_frames):
        if frame in schedule:
            i = int(rng.choice(np.flatnonzero(players.busy_until < frame)))
            j = players.nearest_free(i, frame)
            players.encounter(i, j, frame, schedule[frame])
            encounters.append(Encounter(schedule[frame], (i, j), frame))
        players.free_goals(frame)
        players.advance(frame)
        boxes[frame, :, :2] = players.pos
        boxes[frame, :, 2] = 0.5 * sizes[:, 2]
        boxes[frame, :, 3:6] = sizes
        boxes[frame, :, 6] = players.yaw
    return PlayersClip(boxes, np.arange(config.n_players, dtype=np.int64), tuple(encounters))


def fuse_boxes(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """The average box of boxes a and b (..., 7): mean centre and size, mean box axis."""
    fused = 0.5 * (a + b)
    fused[..., 6] = axis_mean(a[..., 6], b[..., 6])[0]
    return fused


def _missed(n_frames: int, n_players: int, noise: DetectionNoise, rng: np.random.Generator) -> NDArray[np.bool_]:
    """(T, P) runs of missed detections: each starts with miss_prob, lasts miss_mean_frames on average."""
    missed = np.zeros((n_frames, n_players), dtype=bool)
    stay = 1.0 - 1.0 / noise.miss_mean_frames
    for frame in range(n_frames):
        previous = missed[frame - 1] if frame else np.zeros(n_players, dtype=bool)
        missed[frame] = rng.random(n_players) < np.where(previous, stay, noise.miss_prob)
    return missed


def _fused_pairs(centres: NDArray[np.float64], distance_m: float) -> list[tuple[int, int]]:
    """Disjoint pairs of players closer than distance_m (BEV), closest first."""
    gap = np.linalg.norm(centres[:, None, :2] - centres[None, :, :2], axis=-1)
    gap[np.tril_indices(len(centres))] = np.inf
    pairs, taken = [], set()
    for flat in np.argsort(gap, axis=None)[: np.count_nonzero(gap < distance_m)]:
        i, j = np.unravel_index(flat, gap.shape)
        if i not in taken and j not in taken:
            pairs.append((int(i), int(j)))
            taken.update((i, j))
    return pairs


def make_tracklets(clip: PlayersClip, noise: DetectionNoise, rng: np.random.Generator) -> list[Tracklets]:
    """One frame of tracklets per ground-truth frame."""
    n_frames, n_players = clip.boxes.shape[:2]
    missed = _missed(n_frames, n_players, noise, rng)
    half = 0.5 * np.max(np.abs(clip.boxes[..., :2]), axis=(0, 1))
    out = []
    for frame in range(n_frames):
        past = np.maximum(np.arange(frame - TRACKLET_LEN + 1, frame + 1), 0)
        seen = np.flatnonzero(~missed[frame])
        boxes = clip.boxes[past][:, seen].transpose(1, 0, 2)  # (N, 3, 7)
        pairs = _fused_pairs(boxes[:, -1], noise.fuse_distance_m) if noise.fuse_distance_m > 0 else []
        alone = np.setdiff1d(np.arange(len(seen)), np.array(pairs, dtype=int).ravel())
        fused = [fuse_boxes(boxes[i], boxes[j]) for i, j in pairs]
        boxes = np.concatenate([boxes[alone], np.array(fused).reshape(-1, TRACKLET_LEN, 7)])
        duplicates = boxes[rng.random(len(boxes)) < noise.duplicate_prob].copy()
        duplicates[..., :2] += rng.normal(0.0, noise.duplicate_sigma_m, (len(duplicates), 1, 2))
        if noise.near_duplicates > 0:
            duplicates = np.concatenate([duplicates, _near_duplicates(boxes, noise, rng)])
        clutter = np.tile(clip.boxes[0, :1], (rng.poisson(noise.false_per_frame), TRACKLET_LEN, 1))
        clutter[:, :, :2] = rng.uniform(-half, half, (len(clutter), 1, 2))
        clutter[:, :, 6] = rng.uniform(-np.pi, np.pi, (len(clutter), 1))
        n_false = len(duplicates) + len(clutter)
        scores = np.concatenate(
            [rng.uniform(*noise.score_range, len(boxes)), rng.uniform(*noise.false_score_range, n_false)]
        )
        boxes = np.concatenate([boxes, duplicates, clutter])
        boxes = boxes + _box_noise(boxes.shape[:2], noise, rng)
        out.append(Tracklets(boxes, scores))
    return out


def _near_duplicates(
    boxes: NDArray[np.float64], noise: DetectionNoise, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Copies of tracklets (N, 3, 7), a Poisson number each, moved a uniform distance in a uniform direction."""
    near = np.repeat(boxes, rng.poisson(noise.near_duplicates, len(boxes)), axis=0)
    away = rng.uniform(*noise.near_distance_m, len(near))
    towards = rng.uniform(-np.pi, np.pi, len(near))
    near[..., :2] += (away[:, None] * np.column_stack([np.cos(towards), np.sin(towards)]))[:, None]
    return near


def _box_noise(shape: tuple[int, ...], noise: DetectionNoise, rng: np.random.Generator) -> NDArray[np.float64]:
    jitter = np.zeros(shape + (7,))
    jitter[..., :3] = rng.normal(0.0, noise.centre_sigma_m, shape + (3,))
    jitter[..., 3:6] = rng.normal(0.0, noise.size_sigma_m, shape + (3,))
    jitter[..., 6] = rng.normal(0.0, noise.yaw_sigma_rad, shape)
    return jitter
