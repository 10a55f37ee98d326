"""Which rays may hit which bounding spheres, compiled with numba: packets of rays, then exact tests.

A sensor's shots come in time order, so consecutive rays point almost the same way. Rays are
taken `PACKET_RAYS` at a time; a packet's rays lie in a cone (the mean origin, the mean
direction, the widest angle to it) widened by how far their origins spread, and a sphere out of
reach of that cone, or beyond the packet's longest ray, is skipped for the whole packet. Each ray then tests exactly
only the spheres its packet kept, so the cost grows with rays plus candidates, not rays x spheres; rays in no
order (tests' random fans) are still right, only slower.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from simgen.render.buffers import grow

PACKET_RAYS = 32
_COS_MARGIN = 1e-9  # widens every packet's cone against rounding
_COS_WIDE = 0.1  # cones wider than about 84 degrees keep every sphere


@numba.njit(cache=True)
def sphere_candidates(
    origins: NDArray, directions: NDArray, slice_of_ray: NDArray, t_max: NDArray, centres: NDArray, radius: NDArray
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(ray, sphere) pairs whose ray passes through the sphere before t_max[ray] (metres).

    Rays: origins and unit directions (N, 3), time slice (N,); spheres: centres (S, M, 3) and
    radius (S, M), metres; a ray meets only the spheres of its slice; sphere s * M + m.
    """
    n = len(slice_of_ray)
    num_spheres = radius.shape[1]
    capacity = max(16, n)
    ray_out = np.empty(capacity, np.int64)
    sphere_out = np.empty(capacity, np.int64)
    kept = np.empty(radius.size, np.int64)
    count = 0
    for start in range(0, n, PACKET_RAYS):
        stop = min(start + PACKET_RAYS, n)
        # The packet's cone: apex at the mean origin, axis the mean direction.
        ox = oy = oz = ax = ay = az = 0.0
        t_far = 0.0
        first_slice, last_slice = slice_of_ray[start], slice_of_ray[start]
        for i in range(start, stop):
            ox += origins[i, 0]
            oy += origins[i, 1]
            oz += origins[i, 2]
            ax += directions[i, 0]
            ay += directions[i, 1]
            az += directions[i, 2]
            t_far = max(t_far, t_max[i])
            first_slice, last_slice = min(first_slice, slice_of_ray[i]), max(last_slice, slice_of_ray[i])
        size = stop - start
        ox, oy, oz = ox / size, oy / size, oz / size
        length = np.sqrt(ax * ax + ay * ay + az * az)
        if length > 0.0:
            ax, ay, az = ax / length, ay / length, az / length
        spread2, cos_cone = 0.0, 1.0
        for i in range(start, stop):
            dx, dy, dz = origins[i, 0] - ox, origins[i, 1] - oy, origins[i, 2] - oz
            spread2 = max(spread2, dx * dx + dy * dy + dz * dz)
            cos_cone = min(cos_cone, directions[i, 0] * ax + directions[i, 1] * ay + directions[i, 2] * az)
        spread = np.sqrt(spread2)
        cos_cone = cos_cone - _COS_MARGIN
        wide = cos_cone < _COS_WIDE  # (nearly) a half-space or more: keep every sphere
        tan_cone = np.sqrt(max(1.0 - cos_cone * cos_cone, 0.0)) / cos_cone if not wide else 0.0
        # Spheres within reach (radius + spread) of the cone. A centre at distance x along the axis
        # and rho from it lies at least (rho - x tan) cos from the cone, so it is skipped where
        # rho > x tan + reach / cos; and where it lies beyond the packet's longest ray.
        num_kept = 0
        for s in range(first_slice, last_slice + 1):
            for m in range(num_spheres):
                reach = radius[s, m] + spread
                vx, vy, vz = centres[s, m, 0] - ox, centres[s, m, 1] - oy, centres[s, m, 2] - oz
                distance2 = vx * vx + vy * vy + vz * vz
                if distance2 >= (t_far + spread + reach) ** 2:
                    continue
                if not wide:
                    along = vx * ax + vy * ay + vz * az
                    bound = along * tan_cone + reach / cos_cone
                    if bound < 0.0 or distance2 - along * along > bound * bound:
                        continue
                kept[num_kept] = s * num_spheres + m
                num_kept += 1
        # Exact tests.
        for i in range(start, stop):
            s = slice_of_ray[i]
            for k in range(num_kept):
                sphere = kept[k]
                if sphere // num_spheres != s:
                    continue
                m = sphere - s * num_spheres
                r = radius[s, m]
                cx = centres[s, m, 0] - origins[i, 0]
                cy = centres[s, m, 1] - origins[i, 1]
                cz = centres[s, m, 2] - origins[i, 2]
                t_mid = cx * directions[i, 0] + cy * directions[i, 1] + cz * directions[i, 2]
                miss2 = cx * cx + cy * cy + cz * cz - t_mid * t_mid
                if miss2 < r * r and t_mid > -r and t_mid - r < t_max[i]:
                    if count == capacity:
                        capacity *= 2
                        ray_out, sphere_out = grow(ray_out, capacity), grow(sphere_out, capacity)
                    ray_out[count] = i
                    sphere_out[count] = sphere
                    count += 1
    return ray_out[:count], sphere_out[:count]
