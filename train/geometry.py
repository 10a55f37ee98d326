"""Exact overlap measures of oriented 3D boxes (numpy in, numpy out).

Box convention: a box is 7 floats ``(x, y, z, length, width, height, yaw)`` in metres and
radians. ``(x, y, z)`` is the box centre, ``length`` runs along the heading, ``width``
across it, ``height`` along z (z up), and ``yaw`` turns the heading counter-clockwise from
+x about z. Boxes only turn about z, so a box is its bird's-eye-view (BEV) rectangle swept
over ``[z - height/2, z + height/2]``. Arrays of boxes are ``(N, 7)``; sizes are
non-negative, and a box of zero area (volume, in 3D) overlaps nothing.

The BEV intersection of two rectangles is computed exactly (up to rounding), in the frame
of the first: its candidate vertices are the 4 + 4 corners and the 16 points where an edge of
the second meets the line of an edge of the first. Each candidate lies on the boundary of one
rectangle, so it is on the boundary of the intersection exactly when it lies in both; that
inside test, with a tolerance of 1e-12 of the larger half-side, is the only decision made, so
identical boxes, shared or collinear edges and nearly parallel edges need no special case (an
edge pair whose angle has a sine under 1e-12 is parallel: its overlap is made of corners).
Sorted by angle about their mean, the candidates trace the convex intersection polygon, whose
area is the shoelace sum. A pair whose circumscribed circles do not overlap, or with a box of
zero area (volume, in 3D), is not clipped and has IoU 0 (never NaN).

DIoU follows the paper: ``IoU_3D - rho^2(c1, c2) / rho^2(a, b)`` with ``rho(c1, c2)`` the
distance between the centres and ``rho(a, b)`` the distance between the two farthest points
of the two boxes, one in each: for convex boxes the largest of the 8 x 8 corner-to-corner
distances, which the paper calls the diameter of the set enclosing both. (It is the diameter
of the union unless one box's own diagonal is longer, as for a small box deep inside a much
larger one.) A centre is the mean of its corners, so ``rho(c1, c2) <= rho(a, b)`` and DIoU
lies in [-1, 1]; where ``rho(a, b) = 0`` (two zero-size boxes at one point) the penalty is 0.
"""

import numpy as np
from numpy.typing import ArrayLike, NDArray

BOX_DIM = 7
_REL_TOL = 1e-12  # inside tests: of the pair's largest half-side
_SIN_PARALLEL = 1e-12  # edges whose angle has a smaller sine are parallel
_NO_ANGLE = 8.0  # sorts missing vertices after every pseudo-angle (which are in [-1, 3])

# Corner offsets in units of (length / 2, width / 2), counter-clockwise.
_UNIT_CORNERS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
_HALF_CORNERS = 0.5 * _UNIT_CORNERS
_SIGNS = np.array([1.0, -1.0])
_CORNERS_XY = _UNIT_CORNERS.T[..., None]  # (2, 4, 1): x and y of each corner
_NEXT = np.array([1, 2, 3, 0])  # corner after each corner
_CANDIDATES = 8 + 16  # intersection vertices: 4 + 4 corners and the crossings of 4 x 4 edge pairs
_RING = np.append(np.arange(_CANDIDATES), 0)[:, None]  # (25, 1): a closed ring's slots

Boxes = NDArray[np.float64]


def _as_boxes(boxes: ArrayLike) -> Boxes:
    arr = np.asarray(boxes, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != BOX_DIM:
        raise ValueError(f"boxes must have shape (N, {BOX_DIM}), got {arr.shape}")
    return arr


def _half_corners(boxes: Boxes) -> NDArray[np.float64]:
    """(..., 4, 2) BEV corners of boxes (..., 7) before turning, about the centre; metres."""
    return _HALF_CORNERS * boxes[..., None, 3:5]


def _minus_plus(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """(2, ...): -x and x (np.stack's result at a third of its cost)."""
    return np.concatenate([-x[None], x[None]])


def _rotate(points: NDArray[np.float64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points (..., M, 2) turned counter-clockwise about the origin by angle (...) radians.

    Written (c x - s y, s x + c y) = c (x, y) + (-s, s) (y, x), bit for bit, as every turn here:
    x - y is x + (-y) in floating point. A turn back by the same angle takes (s, -s).
    """
    sin = np.sin(angle)
    return np.cos(angle)[..., None, None] * points + np.stack([-sin, sin], axis=-1)[..., None, :] * points[..., ::-1]


def bev_corners(boxes: ArrayLike) -> NDArray[np.float64]:
    """(N, 4, 2) BEV corners (x, y) in metres, counter-clockwise, front-left first."""
    arr = _as_boxes(boxes)
    return arr[:, None, :2] + _rotate(_half_corners(arr), arr[:, 6])


def _clipped_area(a: Boxes, b: Boxes) -> NDArray[np.float64]:
    """(K,) area in m^2 of the BEV intersection of matched rows of a and b (K, 7).

    Arrays are laid out (x and y, candidate, K): a numpy call per step for all pairs, and sums over
    the candidates in their order.
    """
    # In a's frame a is [-l/2, l/2] x [-w/2, w/2] and b is turned by the yaw difference.
    k = len(a)
    half_a, half_b = 0.5 * a.T[3:5, None], 0.5 * b.T[3:5, None]  # (2, 1, K)
    turn = b[:, 6] - a[:, 6]
    cos_turn, sin_turn = np.cos(turn), np.sin(turn)
    sin_pm = _minus_plus(sin_turn)[:, None]  # turns as _rotate does
    cos_a, sin_a = np.cos(a[:, 6]), np.sin(a[:, 6])
    gap = (b[:, :2] - a[:, :2]).T
    centre_b = (cos_a * gap + _minus_plus(sin_a)[::-1] * gap[::-1])[:, None]  # (2, 1, K)
    points = np.empty((2, _CANDIDATES, k))  # candidates: 4 + 4 corners, then the crossings
    np.multiply(_CORNERS_XY, half_a, out=points[:, :4])
    corners_b = points[:, 4:8]
    local = _CORNERS_XY * half_b
    np.add(centre_b, cos_turn * local + sin_pm * local[::-1], out=corners_b)

    # Edge j of b meets the line of a's edges where coordinate c is +-half_a[c] at t along
    # the edge; `other` is the other coordinate there. Shapes (2 c, 4 edges, 2 signs, K).
    edges = corners_b[:, _NEXT] - corners_b  # (2, 4, K)
    steep = np.abs(edges) > _SIN_PARALLEL * np.hypot(edges[0], edges[1])
    level = half_a * _SIGNS[:, None]  # (2 c, 2 signs, K)
    t = (level[:, None] - corners_b[:, :, None]) / np.where(steep, edges, 1.0)[:, :, None]
    other = corners_b[::-1, :, None] + t * edges[::-1, :, None]
    crossings = points[:, 8:].reshape(2, 4, 2, 2, k)  # (x and y, 4 edges, 2 c, 2 signs, K)
    crossings[0, :, 0], crossings[1, :, 1] = level[0], level[1]
    crossings[1, :, 0], crossings[0, :, 1] = other[0], other[1]

    # Every candidate lies on the boundary of a or of b by construction, so it is a vertex
    # or a boundary point of the intersection exactly when it lies in both rectangles.
    tol = _REL_TOL * np.maximum(np.maximum(half_a[0], half_a[1]), np.maximum(half_b[0], half_b[1]))  # (1, K)
    from_b = points - centre_b
    in_b = cos_turn * from_b + sin_pm[::-1] * from_b[::-1]  # turned back by the yaw difference
    inside = (np.abs(points) <= half_a + tol) & (np.abs(in_b) <= half_b + tol)
    valid = inside[0] & inside[1]  # (24, K)
    valid.reshape(6, 2, 2, k)[2:] &= steep.transpose(1, 0, 2)[:, :, None]

    count = valid.sum(axis=0)
    # Summed as (24, x and y and K) numpy adds the candidates one after another (a contiguous axis it sums pairwise).
    weighted = np.multiply(points.transpose(1, 0, 2), valid[:, None], out=np.empty((_CANDIDATES, 2, k)))
    rel = points - weighted.sum(axis=0)[:, None] / np.maximum(count, 1)  # about the pivot
    # Pseudo-angle: increases with the true angle about the pivot, cheaper than arctan2.
    size = np.abs(rel)
    span = size[0] + size[1]
    slope = rel[1] / np.where(span > 0.0, span, 1.0)
    key = np.where(valid, np.where(rel[0] >= 0.0, slope, 2.0 - slope), _NO_ANGLE)
    order = np.argsort(key, axis=0)  # (24, K)
    # Missing vertices sort last; repeat the last real vertex there (zero-length edges).
    column = np.arange(k)
    vertex = np.take(order, np.minimum(_RING, np.maximum(count - 1, 0)) * k + column)  # (25, K)
    ring = np.take(rel.reshape(2, -1), (vertex * k + column).T, axis=1)  # (2, K, 25), closed
    ring, after = ring[..., :-1], ring[..., 1:]
    return 0.5 * np.sum(ring[0] * after[1] - ring[1] * after[0], axis=1)


def _z_range(boxes: Boxes) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(bottom, top) heights in metres of boxes (..., 7), each (...)."""
    return boxes[..., 2] - 0.5 * boxes[..., 5], boxes[..., 2] + 0.5 * boxes[..., 5]


def _iou(a: Boxes, b: Boxes, three_d: bool, gap_bev_sq: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """BEV or 3D IoU of broadcastable box arrays a, b (..., 7), e.g. (P, 1, 7) and (1, Q, 7).

    gap_bev_sq: the squared BEV centre distances in m^2, where the caller has them. Pairs that
    cannot overlap (circumscribed circles apart, zero size, no common height) are never clipped.
    """
    shape = a.shape[:-1] if a.shape == b.shape else np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    if gap_bev_sq is None:
        gap_bev_sq = (a[..., 0] - b[..., 0]) ** 2 + (a[..., 1] - b[..., 1]) ** 2
    size_a, size_b = a[..., 3] * a[..., 4], b[..., 3] * b[..., 4]
    reach = 0.5 * (np.hypot(a[..., 3], a[..., 4]) + np.hypot(b[..., 3], b[..., 4]))
    near = gap_bev_sq < reach**2
    if three_d:
        (bottom_a, top_a), (bottom_b, top_b) = _z_range(a), _z_range(b)
        height = np.minimum(top_a, top_b) - np.maximum(bottom_a, bottom_b)
        height = height if height.shape == shape else np.broadcast_to(height, shape)
        size_a, size_b = size_a * a[..., 5], size_b * b[..., 5]
        near &= height > 0.0
    near &= (size_a > 0.0) & (size_b > 0.0)
    pairs = np.nonzero(near)
    inter = np.zeros(shape)
    inter[pairs] = _clipped_area(
        (a if a.shape[:-1] == shape else np.broadcast_to(a, shape + (BOX_DIM,)))[pairs],
        (b if b.shape[:-1] == shape else np.broadcast_to(b, shape + (BOX_DIM,)))[pairs],
    )
    if three_d:
        inter[pairs] *= height[pairs]
    union = size_a + size_b - inter
    return np.divide(inter, union, out=np.zeros(shape), where=near & (union > 0.0)).clip(0.0, 1.0)


def bev_iou(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(P, Q) exact IoU of the BEV rectangles of boxes a (P, 7) and b (Q, 7)."""
    return _iou(_as_boxes(a)[:, None], _as_boxes(b)[None], three_d=False)


def iou_3d(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(P, Q) exact 3D IoU of boxes a (P, 7) and b (Q, 7)."""
    return _iou(_as_boxes(a)[:, None], _as_boxes(b)[None], three_d=True)


def bev_iou_pairs(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(N,) exact BEV IoU of row i of a (N, 7) with row i of b (N, 7)."""
    arr_a, arr_b = _as_boxes(a), _as_boxes(b)
    if arr_a.shape != arr_b.shape:
        raise ValueError(f"paired boxes differ in shape: {arr_a.shape} and {arr_b.shape}")
    return _iou(arr_a, arr_b, three_d=False)


def iou_3d_pairs(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(N,) exact 3D IoU of row i of a (N, 7) with row i of b (N, 7)."""
    arr_a, arr_b = _as_boxes(a), _as_boxes(b)
    if arr_a.shape != arr_b.shape:
        raise ValueError(f"paired boxes differ in shape: {arr_a.shape} and {arr_b.shape}")
    return _iou(arr_a, arr_b, three_d=True)


def _half_diagonals_xy(boxes: Boxes) -> NDArray[np.float64]:
    """(2 corners, 2 x and y, ...) BEV offsets in metres from the centre of boxes (..., 7) to corners 0 and 1."""
    leading = (1,) * (boxes.ndim - 1)
    half = _HALF_CORNERS[:2].reshape((2, 2, *leading)) * boxes[..., 3:5].transpose(-1, *range(len(leading)))
    return np.cos(boxes[..., 6]) * half + _minus_plus(np.sin(boxes[..., 6])) * half[:, ::-1]  # turned as _rotate does


def _corner_spread_xy(a: Boxes, b: Boxes, dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest squared BEV distance in m^2 from a corner of a to one of b, broadcastable (..., 7).

    dx, dy (...): a's centre less b's, metres. With d the centre offset, corners of a at its centre
    + s e_i and of b at its centre + u f_j (s, u = +-1; e_i, f_j for i, j = 0, 1 the half-diagonals
    to corners 0 and 1), the largest |d + s e_i - u f_j|^2 over the signs is
    |e|^2 + |f|^2 + |d|^2 + 2 max(|x - y| - z, |x + y| + z) where x = d.e_i, y = d.f_j and z = e_i.f_j.
    """
    e, f = _half_diagonals_xy(a), _half_diagonals_xy(b)  # (2 i, 2, ...), (2 j, 2, ...)
    x = (dx * e[:, 0] + dy * e[:, 1])[:, None]  # (2 i, 1, ...)
    y = (dx * f[:, 0] + dy * f[:, 1])[None]  # (1, 2 j, ...)
    z = e[:, None, 0] * f[None, :, 0] + e[:, None, 1] * f[None, :, 1]  # (2 i, 2 j, ...)
    best = np.maximum(np.abs(x - y) - z, np.abs(x + y) + z).max(axis=(0, 1))
    radii = (e[0, 0] ** 2 + e[0, 1] ** 2) + (f[0, 0] ** 2 + f[0, 1] ** 2)
    return radii + dx * dx + dy * dy + 2.0 * best


def _diou(a: Boxes, b: Boxes) -> NDArray[np.float64]:
    """DIoU of broadcastable box arrays a, b (..., 7), e.g. (P, 1, 7) and (1, Q, 7)."""
    dx, dy, dz = a[..., 0] - b[..., 0], a[..., 1] - b[..., 1], a[..., 2] - b[..., 2]
    gap_bev_sq = dx * dx + dy * dy
    (bottom_a, top_a), (bottom_b, top_b) = _z_range(a), _z_range(b)
    spread_z = np.maximum(np.abs(top_a - bottom_b), np.abs(top_b - bottom_a))
    spread = _corner_spread_xy(a, b, dx, dy) + spread_z * spread_z
    penalty = np.divide(gap_bev_sq + dz * dz, spread, out=np.zeros_like(spread), where=spread > 0.0)
    return _iou(a, b, True, gap_bev_sq) - penalty.clip(0.0, 1.0)


def diou_3d(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(P, Q) DIoU of boxes a (P, 7) and b (Q, 7), in [-1, 1] (see the module docstring)."""
    return _diou(_as_boxes(a)[:, None], _as_boxes(b)[None])


def diou_3d_pairs(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(N,) DIoU of row i of a (N, 7) with row i of b (N, 7)."""
    arr_a, arr_b = _as_boxes(a), _as_boxes(b)
    if arr_a.shape != arr_b.shape:
        raise ValueError(f"paired boxes differ in shape: {arr_a.shape} and {arr_b.shape}")
    return _diou(arr_a, arr_b)
