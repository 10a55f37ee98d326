"""The renderer: exact geometry, occlusion, and shots accounted for."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.body.mesh import body_meshes
from simgen.motion.clip import MotionClip
from simgen.render.frame import render_frame
from simgen.render.world import World
from simgen.scan.rays import Rays
from simgen.scenario import NoiseConfig
from simgen.scene.static import build_static_scene
from simgen.vocab import BALL, GROUND, KEYPOINT_INDEX, LINE, PLAYER, SURROUNDINGS
from tests.support.clips import still_clip
from tests.support.poses import PRESETS, keypoints

EXACT = NoiseConfig(enabled=False, min_range_m=0.0)


def rays_towards(origin, directions, time_s=0.5) -> Rays:
    directions = np.asarray(directions, dtype=np.float64)
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    n = len(directions)
    return Rays(
        np.tile(np.asarray(origin, float), (n, 1)),
        directions,
        np.full(n, time_s),
        np.zeros(n, np.uint8),
        np.zeros(n, np.uint8),
    )


def fan(origin, target, half_width_rad, count) -> Rays:
    """A square grid of rays round the direction from origin to target."""
    forward = np.asarray(target, float) - origin
    forward /= np.linalg.norm(forward)
    side = np.cross(forward, [0, 0, 1.0])
    side /= np.linalg.norm(side)
    up = np.cross(side, forward)
    a = np.linspace(-half_width_rad, half_width_rad, count)
    u, v = np.meshgrid(a, a)
    return rays_towards(origin, forward + u.reshape(-1, 1) * side + v.reshape(-1, 1) * up)


def test_ray_hits_board_and_ground_at_analytic_range():
    clip = still_clip([keypoints(PRESETS["standing"], position_m=(30, 0))], ["left"])
    world = World(clip, build_static_scene(surroundings=True))
    board_face_y = 34 + 4.0 - 0.025  # the board behind the touchline y = +34, 5 cm thick
    rays = rays_towards((3.0, 0.0, 0.5), [[0, 1, 0], [0, 1, -0.1]])
    frame = render_frame(world, rays, 0.45, EXACT, np.random.default_rng(0))
    np.testing.assert_allclose(frame.points_m[:, 1], [board_face_y, 5.0], atol=1e-3)
    assert list(frame.semantic) == [SURROUNDINGS, GROUND]
    np.testing.assert_allclose(frame.points_m[1], [3.0, 5.0, 0], atol=1e-3)


def moller_trumbore(origin, directions, triangles) -> np.ndarray:
    """Nearest hit distance of each ray over all triangles (N, 3, 3), brute force; inf if none."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2 = b - a, c - a
    p = np.cross(directions[:, None], e2[None])  # (R, T, 3)
    det = np.einsum("rti,ti->rt", p, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = origin - a
        u = np.einsum("rti,ti->rt", p, s) * inv
        q = np.cross(s, e1)
        v = np.einsum("ri,ti->rt", directions, q) * inv
        t = np.einsum("ti,ti->t", e2, q)[None] * inv
    hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(hit, t, np.inf).min(axis=1)


def test_ray_hits_body_where_an_independent_intersector_does():
    kp = keypoints(PRESETS["running"], yaw_rad=0.7, position_m=(12.0, 3.0))
    clip = still_clip([kp], ["right"])
    world = World(clip, build_static_scene(goals=False))
    origin = np.array([0.0, 0.0, 1.2])
    rays = fan(origin, kp[KEYPOINT_INDEX["middle"]], np.radians(6), 61)
    frame = render_frame(world, rays, 0.45, EXACT, np.random.default_rng(0))
    mesh = body_meshes(kp[None], ["right"])
    nearest = moller_trumbore(origin, rays.direction, mesh.vertices_m[0][mesh.faces].astype(np.float64))
    on_body = frame.semantic == PLAYER
    assert on_body.sum() > 150
    assert on_body.sum() == np.isfinite(nearest).sum()
    ours = np.sort(np.linalg.norm(frame.points_m[on_body] - origin, axis=1))
    np.testing.assert_allclose(ours, np.sort(nearest[np.isfinite(nearest)]), atol=1e-3)


def test_player_hidden_behind_another_gets_no_points():
    origin = np.array([0.0, -20.0, 1.0])
    near = keypoints(PRESETS["standing"], yaw_rad=np.pi / 2, position_m=(0.0, -10.0))
    # The far player is the near one moved 1.5 m further along the line of sight through its middle.
    line = near[KEYPOINT_INDEX["middle"]] - origin
    far = near + 1.5 * line / np.linalg.norm(line)
    world = World(still_clip([near, far], ["left", "right"]), build_static_scene(goals=False))
    rays = fan(origin, near[KEYPOINT_INDEX["middle"]], np.radians(8), 121)
    frame = render_frame(world, rays, 0.45, EXACT, np.random.default_rng(0))
    assert (frame.instance_id == 0).sum() > 500
    assert (frame.instance_id == 1).sum() == 0
    # Without the near player, the far one is seen.
    alone = World(still_clip([far], ["right"]), build_static_scene(goals=False))
    assert (render_frame(alone, rays, 0.45, EXACT, np.random.default_rng(0)).semantic == PLAYER).sum() > 300


def test_ball_lines_and_every_shot_accounted_for():
    clip = still_clip([keypoints(PRESETS["standing"], position_m=(5, 5))], ["official"], ball=(0.0, 9.15, 0.11))
    world = World(clip, build_static_scene(goals=True))
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(20000, 3))
    directions[:, 2] = -np.abs(directions[:, 2])
    directions[:10, :] = [0.0, 9.15, 0.11 - 3.0]  # at the ball
    rays = rays_towards((0.0, 0.0, 3.0), directions)
    noise = NoiseConfig(dropout=0.1)
    frame = render_frame(world, rays, 0.45, noise, rng)
    assert len(frame.points_m) == frame.shots - frame.dropped - frame.missed
    assert frame.dropped == pytest.approx(0.1 * (frame.shots - frame.missed), rel=0.1)
    ball = frame.semantic == BALL
    assert ball.sum() >= 5 and (frame.instance_id[ball] == 1000).all()
    np.testing.assert_allclose(np.linalg.norm(frame.points_m[ball] - [0.0, 9.15, 0.11], axis=1), 0.11, atol=0.1)
    assert (frame.semantic == LINE).sum() > 10
    # Lines are brighter than grass.
    assert frame.intensity[frame.semantic == LINE].mean() > frame.intensity[frame.semantic == GROUND].mean()


def _sprinter() -> tuple[MotionClip, Rays]:
    """A player running 8 m/s along x, 10 m from a sensor, and a 100 ms sweep of 40,000 shots at him."""
    kp = keypoints(PRESETS["standing"], yaw_rad=0.0, position_m=(0.0, 10.0))
    frames = np.stack([kp + [8.0 * t, 0, 0] for t in np.arange(11) * 0.1])
    clip = still_clip([kp], ["left"])
    clip = MotionClip(**{**clip.__dict__, "keypoints_m": frames[:, None].astype(np.float32)})
    rng = np.random.default_rng(0)
    n = 40000
    directions = np.stack([rng.uniform(-0.2, 0.3, n), np.ones(n), rng.uniform(-0.15, 0.05, n)], axis=1)
    rays = Rays(
        np.tile([0.0, 0.0, 1.0], (n, 1)),
        directions / np.linalg.norm(directions, axis=1, keepdims=True),
        np.linspace(0.2, 0.3, n),
        np.zeros(n, np.uint8),
        np.zeros(n, np.uint8),
    )
    return clip, rays


def test_a_snapshot_sees_a_moving_player_where_his_box_is_at_the_label_time():
    """`scan.timing: snapshot`: every shot meets the scene at 0.25 s; all the sprinter's points lie in his box
    at 0.25 s (2 mm for the mesh's float32), all carry that time; the sweep's points spread 0.8 m beyond it."""
    from simgen.labels.boxes import label_poses
    from simgen.qa.label_checks import in_box

    clip, rays = _sprinter()
    world = World(clip, build_static_scene(goals=False))
    box = label_poses(clip, np.array([0.25]))[2][0, 0]
    snapshot = render_frame(world, rays, 0.2, EXACT, np.random.default_rng(0), snapshot_s=0.25)
    sweep = render_frame(world, rays, 0.2, EXACT, np.random.default_rng(0))
    body, swept = snapshot.points_m[snapshot.instance_id == 0], sweep.points_m[sweep.instance_id == 0]
    assert len(body) > 100 and in_box(body, box, 0.002).all()
    np.testing.assert_allclose(snapshot.time_offset_s, 0.05, atol=1e-7)
    assert (~in_box(swept, box, 0.002)).sum() > 0.3 * len(swept)
    assert np.ptp(swept[:, 0]) > np.ptp(body[:, 0]) + 0.6


def test_fast_player_smears_within_a_sweep():
    """Points of a player running 8 m/s across a 100 ms sweep spread along the run by about 0.8 m."""
    clip, rays = _sprinter()
    world = World(clip, build_static_scene(goals=False))
    rng = np.random.default_rng(0)
    frame = render_frame(world, rays, 0.2, EXACT, rng)
    body = frame.instance_id == 0
    early = body & (frame.time_offset_s < 0.02)
    late = body & (frame.time_offset_s > 0.08)
    shift_m = frame.points_m[late, 0].mean() - frame.points_m[early, 0].mean()
    elapsed_s = frame.time_offset_s[late].mean() - frame.time_offset_s[early].mean()
    assert early.sum() > 20 and late.sum() > 20
    assert shift_m == pytest.approx(8.0 * elapsed_s, abs=0.1)


def test_captured_clip_points_fall_with_range_and_shots_add_up(motion_clip):
    """A Mid-100 on the touchline over the committed engine clip: the sparse-LiDAR reality."""
    from simgen.pipeline.clip import render_clip
    from simgen.scenario import parse_scenario

    scenario = parse_scenario({"name": "t", "scan": {"frames": 20}, "scene": {"surroundings": True}})
    frames = list(render_clip(scenario, motion_clip, 0))
    assert len(frames) == 20
    ranges, counts = [], []
    sensor = np.array([scenario.sensors[0].pose.x, scenario.sensors[0].pose.y, scenario.sensors[0].pose.z])
    for frame in frames:
        scan = frame.scan
        assert scan.shots == 30000  # Mid-100 at x1, 10 Hz
        assert len(scan.points_m) == scan.shots - scan.dropped - scan.missed
        players = frame.labels.team != "official"
        ranges.append(np.linalg.norm(frame.labels.boxes[players, :2] - sensor[:2], axis=1))
        counts.append(frame.labels.num_points[players])
        assert set(np.unique(scan.instance_id)) <= set(frame.labels.track_id) | {-1, 1000}
    ranges, counts = np.concatenate(ranges), np.concatenate(counts)
    near, middle, far = (np.median(counts[(ranges >= lo) & (ranges < hi)]) for lo, hi in ((0, 25), (25, 45), (45, 120)))
    assert near > middle > far, (near, middle, far)
    assert (counts == 0).any()  # some players get no point at all in a frame


def test_points_carry_the_sweep_of_their_shot(motion_clip):
    """Two 20 Hz sweeps merged into a 10 Hz frame: the first 50 ms of shots are sweep 0, the rest
    sweep 1, and a shard of the clip renders the same frames bit for bit."""
    from simgen.pipeline.clip import label_sizes, render_clip, render_frames
    from simgen.scenario import parse_scenario

    scenario = parse_scenario({"name": "t", "scan": {"frames": 4, "sweeps_per_frame": 2}})
    frames = list(render_clip(scenario, motion_clip, 0))
    for frame in frames:
        scan = frame.scan
        assert set(np.unique(scan.sweep)) == {0, 1}
        assert (
            scan.time_offset_s[scan.sweep == 0].max() <= 0.05 + 1e-6 < scan.time_offset_s[scan.sweep == 1].min() + 1e-6
        )
    single = parse_scenario({"name": "t", "scan": {"frames": 4}})
    assert all((f.scan.sweep == 0).all() for f in render_clip(single, motion_clip, 0))
    shards = list(render_frames(scenario, motion_clip, 0, 2, 4, label_sizes(scenario, motion_clip)))
    assert len(frames) == 4 and len(shards) == 2
    for whole, shard in zip(frames[2:], shards, strict=True):
        assert shard.index == whole.index
        for name in ("points_m", "intensity", "time_offset_s", "sweep", "instance_id"):
            np.testing.assert_array_equal(getattr(shard.scan, name), getattr(whole.scan, name))
        np.testing.assert_array_equal(shard.labels.boxes, whole.labels.boxes)
