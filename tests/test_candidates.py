"""The search for the bounding spheres a ray passes through: exactly the brute-force pairs."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from simgen.render.candidates import PACKET_RAYS, sphere_candidates


def brute_force(origins, directions, slice_of_ray, t_max, centres, radius) -> set[tuple[int, int]]:
    pairs = set()
    num_spheres = radius.shape[1]
    for i in range(len(origins)):
        s = slice_of_ray[i]
        to_centre = centres[s] - origins[i]
        t_mid = to_centre @ directions[i]
        miss2 = np.einsum("mi,mi->m", to_centre, to_centre) - t_mid**2
        hit = (miss2 < radius[s] ** 2) & (t_mid > -radius[s]) & (t_mid - radius[s] < t_max[i])
        pairs |= {(i, s * num_spheres + m) for m in np.nonzero(hit)[0]}
    return pairs


def sweep(rng, n, origins):
    """Rays in time order along a rose-like curve, as a sensor fires them, from one of `origins`."""
    phase = np.cumsum(rng.uniform(0.001, 0.01, n))
    azimuth, elevation = 0.6 * np.sin(3 * phase), -0.2 + 0.15 * np.cos(5 * phase)
    directions = np.stack(
        [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)], axis=1
    )
    return origins[np.repeat(np.arange(len(origins)), -(-n // len(origins)))[:n]], directions


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(0, 5 * PACKET_RAYS), ordered=st.booleans(), sensors=st.integers(1, 3))
def test_finds_exactly_the_brute_force_pairs(seed, n, ordered, sensors):
    rng = np.random.default_rng(seed)
    origins_of_sensors = rng.uniform(-5, 5, (sensors, 3)) + [0, 0, 4]
    if ordered:
        origins, directions = sweep(rng, n, origins_of_sensors)
    else:  # a random fan: no order to exploit
        origins = origins_of_sensors[rng.integers(0, sensors, n)]
        directions = rng.normal(size=(n, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    num_slices, num_spheres = 3, 12
    slice_of_ray = np.sort(rng.integers(0, num_slices, n)) if ordered else rng.integers(0, num_slices, n)
    centres = rng.uniform([2, -15, 0], [30, 15, 2], (num_slices, num_spheres, 3))
    radius = rng.uniform(0.1, 2.0, (num_slices, num_spheres))
    t_max = np.where(rng.random(n) < 0.2, np.inf, rng.uniform(1, 40, n))
    ray, sphere = sphere_candidates(origins, directions, slice_of_ray, t_max, centres, radius)
    found = set(zip(ray.tolist(), sphere.tolist()))
    assert len(found) == len(ray)  # no pair twice
    assert found == brute_force(origins, directions, slice_of_ray, t_max, centres, radius)


def test_a_sphere_round_the_sensor_is_a_candidate_of_every_ray():
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(100, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origins = np.zeros((100, 3))
    ray, _ = sphere_candidates(
        origins, directions, np.zeros(100, np.int64), np.full(100, np.inf), np.zeros((1, 1, 3)), np.ones((1, 1))
    )
    assert sorted(ray) == list(range(100))
