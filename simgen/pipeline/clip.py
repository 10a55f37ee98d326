"""One clip through the pipeline: motion -> scene -> scan -> labels, frame by frame.

Randomness: the engine's seed and every frame's noise come from `numpy.random.SeedSequence`
keyed by (scenario seed, clip index[, frame index]), so clips and frames can be made in any
order, by any worker, with identical results.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

from simgen.errors import UserError
from simgen.labels.boxes import frame_labels, label_poses, placed_between, track_sizes, with_track_sizes
from simgen.labels.labelled_frame import LabelledFrame
from simgen.motion.clip import MotionClip
from simgen.render.frame import render_frame
from simgen.render.world import World
from simgen.scan.sensor import scenario_sensors
from simgen.scan.sensor_rig import frame_rays
from simgen.scenario import Scenario
from simgen.scene.static import build_static_scene

LABEL_CHUNK_FRAMES = 50  # frames whose labels are computed at once


def clip_name(clip_index: int) -> str:
    return f"clip_{clip_index:04d}"


def engine_seed(scenario: Scenario, clip_index: int) -> int:
    """The football engine's seed for a clip (the first clip of seed S plays as `simgen capture --seed S`)."""
    if clip_index == 0:
        return scenario.seed
    return int(np.random.SeedSequence([scenario.seed, clip_index]).generate_state(1)[0] % 2**31)


def frame_count(scenario: Scenario, clip: MotionClip) -> int:
    """Frames the clip's motion covers at the scan's frame rate (or the scenario's `scan.frames`)."""
    span_s = clip.time_s[-1] - clip.time_s[0]
    available = math.floor(span_s * scenario.scan.frame_rate_hz + 1e-9)
    wanted = scenario.scan.frames or available
    if wanted > available:
        raise UserError(
            f"scan.frames: {wanted} frames at {scenario.scan.frame_rate_hz:g} Hz need "
            f"{wanted / scenario.scan.frame_rate_hz:.1f} s of motion, the clip has {span_s:.1f} s (raise motion.frames)"
        )
    return wanted


def render_clip(scenario: Scenario, clip: MotionClip, clip_index: int) -> Iterator[LabelledFrame]:
    """Yield the clip's labelled frames in order."""
    return render_frames(scenario, clip, clip_index, 0, frame_count(scenario, clip), label_sizes(scenario, clip))


def render_frames(
    scenario: Scenario, clip: MotionClip, clip_index: int, first: int, stop: int, sizes: NDArray | None
) -> Iterator[LabelledFrame]:
    """Yield frames `first` .. `stop - 1` of the clip, in order: the same frames, bit for bit, as
    `render_clip` yields there (a shard of a clip), `sizes` being the clip's `label_sizes`. Labels are
    computed `LABEL_CHUNK_FRAMES` at a time on chunks aligned to the clip's frame 0 whatever `first` is."""
    scene = scenario.scene
    world = World(clip, build_static_scene(scene.goals, scene.surroundings, scene.net_transmission))
    rate = scenario.scan.frame_rate_hz
    start = float(clip.time_s[0])
    sensors = scenario_sensors(scenario)
    for index in range(first, stop):
        j = index % LABEL_CHUNK_FRAMES
        if j == 0 or index == first:  # labels of the chunk's frames at once (none past `stop`: no motion there)
            label_times, keypoints, velocity, boxes, discontinuity = chunk_labels(scenario, clip, sizes, index, stop)
        frame_start = start + index / rate
        rays = frame_rays(scenario.scan, sensors, index, start)
        rng = np.random.default_rng(np.random.SeedSequence([scenario.seed, clip_index, index]))
        snapshot_s = float(label_times[j]) if scenario.scan.timing == "snapshot" else None
        scan = render_frame(world, rays, frame_start, scenario.noise, rng, snapshot_s)
        labels = frame_labels(
            boxes[j], keypoints[j], velocity[j], clip.track_id, clip.team, clip.role, scan.instance_id, discontinuity[j]
        )
        yield LabelledFrame(clip_name(clip_index), index, frame_start, float(label_times[j]), scan, labels)


def label_sizes(scenario: Scenario, clip: MotionClip) -> NDArray[np.float64] | None:
    """labels.size: track: one size (H, 3) in m per humanoid over the whole clip, whatever part of it is rendered."""
    if scenario.labels.size != "track":
        return None
    rate = scenario.scan.frame_rate_hz
    return track_sizes(clip, float(clip.time_s[0]) + (np.arange(frame_count(scenario, clip)) + 0.5) / rate)


def chunk_labels(
    scenario: Scenario, clip: MotionClip, sizes: NDArray | None, index: int, stop: int
) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
    """Label times (s), keypoints, velocities, boxes and placement flags of the frames from `index` to the end
    of its `LABEL_CHUNK_FRAMES` chunk (aligned to frame 0, cut at `stop`): the same floats whatever `index`."""
    rate = scenario.scan.frame_rate_hz
    start = float(clip.time_s[0])
    j = index % LABEL_CHUNK_FRAMES
    chunk = index - j + np.arange(min(LABEL_CHUNK_FRAMES, stop - index + j))
    label_times = start + (chunk + 0.5) / rate
    keypoints, velocity, boxes = label_poses(clip, label_times)
    boxes = boxes if sizes is None else with_track_sizes(boxes, sizes)
    # the previous frame's label time (the same floats as its own) to the end of this frame's sweep
    discontinuity = placed_between(clip, start + (chunk - 0.5) / rate, start + (chunk + 1) / rate)
    return label_times, keypoints, velocity, boxes, discontinuity


def frame_boxes(scenario: Scenario, clip: MotionClip, sizes: NDArray | None, index: int) -> NDArray[np.float32]:
    """Frame `index`'s label boxes (H, 7), as `render_frames` labels them with the same `sizes`, without
    rendering its scan."""
    boxes = chunk_labels(scenario, clip, sizes, index, index + 1)[3]
    return np.asarray(boxes[index % LABEL_CHUNK_FRAMES], np.float32)
