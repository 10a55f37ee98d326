"""The noise model, measured on rendered points: range and angle noise, range limits, dropout, sub-rays."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.render.frame import render_frame
from simgen.render.noise import ReturnModel, max_range_m, noisy_returns
from simgen.render.world import World
from simgen.scan.rays import Rays
from simgen.scenario import NoiseConfig
from simgen.scene.static import build_static_scene
from simgen.vocab import BALL
from tests.support.clips import still_clip
from tests.support.poses import PRESETS, keypoints

HEIGHT_M = 10.0


def rays_down(n: int, spread_rad: float = 0.3, seed: int = 0) -> Rays:
    """n rays from 10 m up, fanned round straight down (they all end on the grass, no player near)."""
    rng = np.random.default_rng(seed)
    directions = np.column_stack([rng.uniform(-spread_rad, spread_rad, (n, 2)), -np.ones(n)])
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return Rays(
        np.tile([0.0, 20.0, HEIGHT_M], (n, 1)),
        directions,
        np.full(n, 0.5),
        np.zeros(n, np.uint8),
        np.zeros(n, np.uint8),
    )


@pytest.fixture(scope="module")
def world():
    return World(
        still_clip([keypoints(PRESETS["standing"], position_m=(-40, -30))], ["left"]), build_static_scene(goals=False)
    )


def exact_ranges(rays: Rays) -> np.ndarray:
    return -rays.origin_m[:, 2] / rays.direction[:, 2]


def test_range_noise_has_the_configured_sigma(world):
    rays = rays_down(20000)
    frame = render_frame(
        world, rays, 0.45, NoiseConfig(range_sigma_m=0.02, angle_sigma_deg=0.0), np.random.default_rng(1)
    )
    error = np.linalg.norm(frame.points_m - rays.origin_m, axis=1) - exact_ranges(rays)
    assert abs(error.mean()) < 0.001
    assert error.std() == pytest.approx(0.02, rel=0.05)


def test_angle_noise_has_the_configured_sigma_per_axis(world):
    rays = rays_down(20000)
    frame = render_frame(
        world, rays, 0.45, NoiseConfig(range_sigma_m=0.0, angle_sigma_deg=0.05), np.random.default_rng(2)
    )
    seen = frame.points_m - rays.origin_m
    seen /= np.linalg.norm(seen, axis=1, keepdims=True)
    angle = np.arccos(np.clip(np.einsum("ni,ni->n", seen, rays.direction), -1, 1))
    # Two independent axes of sigma each: the mean squared angle is 2 sigma^2.
    assert np.sqrt(np.mean(angle**2) / 2) == pytest.approx(np.radians(0.05), rel=0.05)


def test_without_noise_points_lie_where_the_rays_meet_the_ground(world):
    rays = rays_down(1000)
    frame = render_frame(world, rays, 0.45, NoiseConfig(enabled=False), np.random.default_rng(0))
    np.testing.assert_allclose(np.linalg.norm(frame.points_m - rays.origin_m, axis=1), exact_ranges(rays), atol=1e-4)


def test_datasheet_ranges_and_grazing_grass_out_of_range():
    assert max_range_m(0.1, 1.0, 90.0) == pytest.approx(90.0)
    assert max_range_m(0.8, 1.0, 90.0) == pytest.approx(254.6, abs=0.1)
    # Grass (0.35) seen at a grazing angle: beyond its reduced range, the shot is missed.
    origin, t = np.array([[0.0, 0.0, 1.0]]), 100.0
    direction = np.array([[np.sqrt(1 - 0.01**2), 0.0, -0.01]])
    model = ReturnModel(subrays=1, min_range_m=1.0, max_range_at_10pct_m=90.0, dropout=0.0, range_sigma_m=0.0,
                        angle_sigma_rad=0.0)
    hits, _, _, missed, dropped = noisy_returns(
        origin, direction, np.array([t]), np.array([0.35]), np.array([0.01]), model, np.random.default_rng(0)
    )
    assert (len(hits), missed, dropped) == (0, 1, 0)


def test_a_wide_beam_returns_from_an_object_its_axis_just_misses():
    """Beam divergence: a shot aimed 1 degree beside a ball in the air (0.63 degree across its radius)
    passes it with one ray per shot, but with sub-rays over a 3 degree footprint its nearest return
    is the ball."""
    ball = np.array([10.0, 0.0, 3.0])
    world = World(
        still_clip([keypoints(PRESETS["standing"], position_m=(-40, -30))], ["left"], ball=tuple(ball)),
        build_static_scene(goals=False),
    )
    origin = np.array([0.0, 0.0, 3.0])
    axis = (ball - origin) / np.linalg.norm(ball - origin)
    side = np.radians(1.0)
    direction = np.array(
        [axis[0] * np.cos(side) - axis[1] * np.sin(side), axis[0] * np.sin(side) + axis[1] * np.cos(side), axis[2]]
    )
    rays = Rays(
        origin[None],
        direction[None] / np.linalg.norm(direction),
        np.array([0.5]),
        np.zeros(1, np.uint8),
        np.zeros(1, np.uint8),
    )
    narrow = render_frame(world, rays, 0.45, NoiseConfig(enabled=False), np.random.default_rng(0))
    wide = render_frame(
        world, rays, 0.45, NoiseConfig(enabled=False, subrays=16, divergence_deg=(3.0, 3.0)), np.random.default_rng(0)
    )
    assert narrow.missed == 1 and list(wide.semantic) == [BALL]  # the narrow beam goes off to the sky
    assert wide.shots == 1 and len(wide.points_m) == 1
    # The point lies along the shot's axis, at the nearest sub-ray's range (as a Livox reports it).
    assert np.linalg.norm(wide.points_m[0] - origin) == pytest.approx(np.linalg.norm(ball - origin) - 0.11, abs=0.05)
