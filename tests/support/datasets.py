"""Hand-made `LabelledFrame`s for the dataset writers' tests and benchmark: scan-like random points and boxes.

Points lie on the ground round a sensor at the touchline and on the humanoids' boxes (those carry
the humanoid's track id), with plausible intensities, time offsets and heads; boxes are
player-sized, anywhere on the pitch, any yaw. The last humanoid of every frame gets no point, as
an occluded one would.
"""

from __future__ import annotations

import numpy as np

from scan_patterns import get_sensor
from simgen.datasets.frame import frame_times
from simgen.labels.boxes import FrameLabels
from simgen.labels.labelled_frame import LabelledFrame
from simgen.render.frame import ScanFrame
from simgen.scan.sensor import Sensor
from simgen.vocab import BALL, BALL_INSTANCE_ID, GROUND, OFFICIAL, PLAYER

FRAME_RATE_HZ = 10.0
FRAME_S = 1 / FRAME_RATE_HZ
START_S = 12.0  # game time of every clip's frame 0
SENSOR_M = np.array([0.0, -36.0, 4.0])


def sensors() -> list[Sensor]:
    return [
        Sensor(
            0,
            "mid100",
            "mid100-risley",
            (0.0, -36.0, 4.0, 0.0, -10.0, 90.0),
            get_sensor("mid100-risley").heads,
            150_000.0,
            FRAME_RATE_HZ,
            1,
            1.0,
        )
    ]


def mid40() -> Sensor:
    """A second sensor for `sensors()`' Mid-100: a Mid-40 (one head) across the pitch."""
    return Sensor(1, "mid40", "mid40-risley", (10.0, 36.0, 6.0, 0.0, -15.0, -90.0), get_sensor("mid40-risley").heads,
                  100_000.0, FRAME_RATE_HZ, 1, 1.0)


def with_mid40(frames: list[LabelledFrame], every: int) -> list[LabelledFrame]:
    """`frames` with every `every`-th point the Mid-40's (sensor 1, head 0), the rest still the Mid-100's."""
    import dataclasses

    out = []
    for frame in frames:
        theirs = np.arange(len(frame.scan.points_m)) % every == 0
        head = np.where(theirs, 0, frame.scan.head)
        scan = dataclasses.replace(frame.scan, sensor=theirs.astype(np.uint8), head=head)
        out.append(dataclasses.replace(frame, scan=scan))
    return out


def _teams(humanoids: int) -> tuple[np.ndarray, np.ndarray]:
    officials = min(3, humanoids)
    players = humanoids - officials
    names = ["left"] * (players - players // 2) + ["right"] * (players // 2) + ["official"] * officials
    team = np.array(names, dtype=np.str_)
    role = np.where(team == "official", "referee", "CM")
    return team, role


def _centres(rng: np.random.Generator, humanoids: int) -> np.ndarray:
    """(H, 3) box centres: on the pitch, standing (0.6-2 m tall boxes) from the ground."""
    return np.column_stack(
        [rng.uniform(-52, 52, humanoids), rng.uniform(-33, 33, humanoids), rng.uniform(0.3, 1.0, humanoids)]
    )


def _labels(rng: np.random.Generator, centre: np.ndarray, instance: np.ndarray) -> FrameLabels:
    humanoids = len(centre)
    size = np.column_stack([rng.uniform(0.3, 1.2, humanoids), rng.uniform(0.3, 0.9, humanoids), 2 * centre[:, 2]])
    yaw = rng.uniform(-np.pi, np.pi, humanoids)
    team, role = _teams(humanoids)
    track_id = np.arange(1, humanoids + 1, dtype=np.int32)
    return FrameLabels(
        boxes=np.column_stack([centre, size, yaw]).astype(np.float32).reshape(-1, 7),
        track_id=track_id,
        team=team,
        role=role,
        velocity_mps=rng.normal(0, 3, (humanoids, 3)).astype(np.float32),
        keypoints_m=(centre[:, None] + rng.normal(0, 0.3, (humanoids, 12, 3))).astype(np.float32),
        num_points=np.array([(instance == t).sum() for t in track_id], np.int32),
        discontinuity=rng.random(humanoids) < 0.1,  # as if the engine had placed some for a restart
    )


def _scan(rng: np.random.Generator, points: int, centres: np.ndarray, team: np.ndarray) -> ScanFrame:
    on_body = min(points // 10, 40 * max(len(centres) - 1, 0))
    ground = points - on_body
    azimuth = rng.uniform(0.2, np.pi - 0.2, ground)
    distance = 4.0 / np.tan(rng.uniform(np.deg2rad(3), np.deg2rad(40), ground))
    height = -SENSOR_M[2] + rng.normal(0, 0.02, ground)  # 2 cm range noise, roughly
    xyz_ground = SENSOR_M + np.column_stack([distance * np.cos(azimuth), distance * np.sin(azimuth), height])
    who = rng.integers(0, max(len(centres) - 1, 1), on_body)
    xyz_body = centres[who] + rng.normal(0, 0.25, (on_body, 3)) if len(centres) > 1 else np.zeros((0, 3))
    instance = np.concatenate([np.full(ground, -1), who + 1]).astype(np.int32)
    semantic = np.concatenate([np.full(ground, GROUND), np.where(team[who] == "official", OFFICIAL, PLAYER)]).astype(
        np.uint8
    )
    if ground:
        instance[0], semantic[0] = BALL_INSTANCE_ID, BALL
    shots = int(points * 1.25)
    return ScanFrame(
        points_m=np.concatenate([xyz_ground, xyz_body]).astype(np.float32),
        intensity=rng.integers(0, 151, points).astype(np.uint8),
        time_offset_s=np.sort(rng.uniform(0, FRAME_S, points)).astype(np.float32),
        sensor=np.zeros(points, np.uint8),
        head=rng.integers(0, 3, points).astype(np.uint8),
        line=rng.integers(0, 6, points).astype(np.uint8),
        instance_id=instance,
        semantic=semantic,
        shots=shots,
        dropped=shots // 20,
        missed=shots - points - shots // 20,
    )


def make_clip(clip: str, frames: int, points: int = 500, humanoids: int = 25, seed: int = 0) -> list[LabelledFrame]:
    """`frames` consecutive frames of clip `clip`; frame sizes vary by up to 10 % round `points`."""
    rng = np.random.default_rng(seed)
    out = []
    for index in range(frames):
        count = int(points * rng.uniform(0.9, 1.1)) if points else 0
        centres = _centres(rng, humanoids)
        scan = _scan(rng, count, centres, _teams(humanoids)[0])
        labels = _labels(rng, centres, scan.instance_id)
        out.append(LabelledFrame(clip, index, *frame_times(START_S, FRAME_RATE_HZ, index), scan, labels))
    return out


def write_dataset(root, format: str, clips: list[list[LabelledFrame]], seed: int = 7):
    """Write `clips` (clip index = position) and finish the dataset; returns its manifest."""
    from simgen.datasets import finish_dataset, write_clip

    records = [write_clip(root, format, frames, sensors(), index) for index, frames in enumerate(clips)]
    return finish_dataset(root, format, records, sensors(), {"name": "factory", "seed": seed}, seed)


def sample_clips() -> list[list[LabelledFrame]]:
    """Three small clips; the last has a frame with no points and one with no humanoid."""
    clips = [make_clip(f"clip_{i:04d}", 4, seed=i) for i in range(2)]
    empty = make_clip("clip_0002", 1, points=0, humanoids=3, seed=5) + make_clip("clip_0002", 1, humanoids=0, seed=6)
    clips.append(
        [
            LabelledFrame(f.clip, i, *frame_times(START_S, FRAME_RATE_HZ, i), f.scan, f.labels)
            for i, f in enumerate(empty)
        ]
    )
    return clips
