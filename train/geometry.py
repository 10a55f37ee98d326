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
_SIGNS = np.array([1.0, -1.0])
_NEXT = [1, 2, 3, 0]  # corner after each corner
_CROSSINGS = 16  # 4 x 4 edge pairs
_CANDIDATES = 8 + _CROSSINGS  # intersection vertices: 4 + 4 corners and the crossings
_RING_NEXT = np.roll(np.arange(_CANDIDATES), -1)

Boxes = NDArray[np.float64]


def _as_boxes(boxes: ArrayLike) -> Boxes:
    arr = np.asarray(boxes, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != BOX_DIM:
        raise ValueError(f"boxes must have shape (N, {BOX_DIM}), got {arr.shape}")
    return arr


def _half_corners(boxes: Boxes) -> NDArray[np.float64]:
    """(..., 4, 2) BEV corners of boxes (..., 7) before turning, about the centre; metres."""
    return 0.5 * _UNIT_CORNERS * boxes[..., None, 3:5]


def _rotate(points: NDArray[np.float64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points (..., M, 2) turned counter-clockwise about the origin by angle (...) radians."""
    return _turn(points, np.cos(angle), np.sin(angle))


def _turn(points: NDArray[np.float64], cos: NDArray[np.float64], sin: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points (..., M, 2) turned counter-clockwise by the angle of cosine and sine (...): cos(-x) and -sin(x) are
    numpy's cos and sin of -x bit for bit, so a turn back needs no new ones."""
    cos, sin = cos[..., None], sin[..., None]
    x, y = points[..., 0], points[..., 1]
    turned = np.empty(np.broadcast_shapes(points.shape, cos.shape + (2,)))
    turned[..., 0] = cos * x - sin * y
    turned[..., 1] = sin * x + cos * y
    return turned


def bev_corners(boxes: ArrayLike) -> NDArray[np.float64]:
    """(N, 4, 2) BEV corners (x, y) in metres, counter-clockwise, front-left first."""
    arr = _as_boxes(boxes)
    return arr[:, None, :2] + _rotate(_half_corners(arr), arr[:, 6])


def _clipped_area(a: Boxes, b: Boxes) -> NDArray[np.float64]:
    """(K,) area in m^2 of the BEV intersection of matched rows of a and b (K, 7)."""
    # In a's frame a is [-l/2, l/2] x [-w/2, w/2] and b is turned by the yaw difference.
    half_a, half_b = 0.5 * a[:, None, 3:5], 0.5 * b[:, None, 3:5]  # (K, 1, 2)
    turn = b[:, 6] - a[:, 6]
    cos_turn, sin_turn = np.cos(turn), np.sin(turn)
    centre_b = _turn((b[:, :2] - a[:, :2])[:, None], np.cos(a[:, 6]), -np.sin(a[:, 6]))  # (K, 1, 2)
    corners_b = centre_b + _turn(_UNIT_CORNERS * half_b, cos_turn, sin_turn)

    # Edge j of b meets the line of a's edges where coordinate c is +-half_a[c] at t along
    # the edge; `other` is the other coordinate there. Shapes (K, 4 edges, 2 c, 2 signs).
    edges = corners_b[:, _NEXT] - corners_b
    steep = np.abs(edges) > _SIN_PARALLEL * np.hypot(edges[..., :1], edges[..., 1:])
    level = np.broadcast_to(half_a[..., None] * _SIGNS, (len(a), 4, 2, 2))
    t = (level - corners_b[..., None]) / np.where(steep, edges, 1.0)[..., None]
    other = corners_b[..., ::-1, None] + t * edges[..., ::-1, None]
    crossings = np.empty(t.shape + (2,))  # (K, 4, 2, 2, x and y)
    crossings[:, :, 0, :, 0], crossings[:, :, 1, :, 1] = level[:, :, 0], level[:, :, 1]
    crossings[:, :, 1, :, 0], crossings[:, :, 0, :, 1] = other[:, :, 1], other[:, :, 0]
    crossings = crossings.reshape(len(a), _CROSSINGS, 2)

    # Every candidate lies on the boundary of a or of b by construction, so it is a vertex
    # or a boundary point of the intersection exactly when it lies in both rectangles.
    points = np.concatenate([_UNIT_CORNERS * half_a, corners_b, crossings], axis=1)  # (K, 24, 2)
    # Reductions over the last axis of 2 are spelled out: numpy's are slow on tiny axes.
    tol = _REL_TOL * np.maximum(np.maximum(half_a[..., 0], half_a[..., 1]),
                                np.maximum(half_b[..., 0], half_b[..., 1]))[..., None]  # (K, 1, 1)
    inside_a = np.abs(points) <= half_a + tol
    inside_b = np.abs(_turn(points - centre_b, cos_turn, -sin_turn)) <= half_b + tol
    valid = inside_a[..., 0] & inside_a[..., 1] & inside_b[..., 0] & inside_b[..., 1]
    valid[:, -_CROSSINGS:] &= np.broadcast_to(steep[..., None], t.shape).reshape(len(a), _CROSSINGS)

    count = valid.sum(axis=1)
    pivot = (points * valid[..., None]).sum(axis=1) / np.maximum(count, 1)[:, None]
    rel = points - pivot[:, None]
    # Pseudo-angle: increases with the true angle about the pivot, cheaper than arctan2.
    span = np.abs(rel[..., 0]) + np.abs(rel[..., 1])
    slope = rel[..., 1] / np.where(span > 0.0, span, 1.0)
    key = np.where(valid, np.where(rel[..., 0] >= 0.0, slope, 2.0 - slope), _NO_ANGLE)
    order = np.argsort(key, axis=1)
    # Missing vertices sort last; repeat the last real vertex there (zero-length edges).
    last = np.maximum(count - 1, 0)[:, None]
    rows = np.arange(len(a))[:, None]
    order = order[rows, np.minimum(np.arange(_CANDIDATES), last)]
    ring = rel[rows, order]
    after = ring[:, _RING_NEXT]
    return 0.5 * np.sum(ring[..., 0] * after[..., 1] - ring[..., 1] * after[..., 0], axis=1)


def _z_range(boxes: Boxes) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(bottom, top) heights in metres of boxes (..., 7), each (...)."""
    return boxes[..., 2] - 0.5 * boxes[..., 5], boxes[..., 2] + 0.5 * boxes[..., 5]


def _iou(a: Boxes, b: Boxes, three_d: bool) -> NDArray[np.float64]:
    """BEV or 3D IoU of broadcastable box arrays a, b (..., 7), e.g. (P, 1, 7) and (1, Q, 7).

    Pairs that cannot overlap (circumscribed circles apart, zero size, no common height)
    are never clipped.
    """
    shape = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    size_a, size_b = a[..., 3] * a[..., 4], b[..., 3] * b[..., 4]
    reach = 0.5 * (np.hypot(a[..., 3], a[..., 4]) + np.hypot(b[..., 3], b[..., 4]))
    near = (a[..., 0] - b[..., 0]) ** 2 + (a[..., 1] - b[..., 1]) ** 2 < reach**2
    if three_d:
        (bottom_a, top_a), (bottom_b, top_b) = _z_range(a), _z_range(b)
        height = np.broadcast_to(np.minimum(top_a, top_b) - np.maximum(bottom_a, bottom_b), shape)
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


def _corner_spread_xy(a: Boxes, b: Boxes) -> NDArray[np.float64]:
    """Largest squared BEV distance in m^2 from a corner of a to one of b, broadcastable (..., 7).

    With d the centre offset, corners of a at its centre + s e_i and of b at its centre + u f_j
    (s, u = +-1; e_i, f_j for i, j = 0, 1 the half-diagonals to corners 0 and 1), the largest
    |d + s e_i - u f_j|^2 over the signs is |e|^2 + |f|^2 + |d|^2 + 2 max(|x - y| - z, |x + y| + z)
    where x = d.e_i, y = d.f_j and z = e_i.f_j.
    """
    e = _rotate(_half_corners(a)[..., :2, :], a[..., 6])  # (..., 2, 2)
    f = _rotate(_half_corners(b)[..., :2, :], b[..., 6])
    dx, dy = a[..., 0] - b[..., 0], a[..., 1] - b[..., 1]
    ys = [dx * f[..., j, 0] + dy * f[..., j, 1] for j in range(2)]
    best = np.full(dx.shape, -np.inf)
    for i in range(2):
        x = dx * e[..., i, 0] + dy * e[..., i, 1]
        for j, y in enumerate(ys):
            z = e[..., i, 0] * f[..., j, 0] + e[..., i, 1] * f[..., j, 1]
            best = np.maximum(best, np.maximum(np.abs(x - y) - z, np.abs(x + y) + z))
    radii = (e[..., 0, 0] ** 2 + e[..., 0, 1] ** 2) + (f[..., 0, 0] ** 2 + f[..., 0, 1] ** 2)
    return radii + dx * dx + dy * dy + 2.0 * best


def _diou(a: Boxes, b: Boxes) -> NDArray[np.float64]:
    """DIoU of broadcastable box arrays a, b (..., 7), e.g. (P, 1, 7) and (1, Q, 7)."""
    gap = a[..., :3] - b[..., :3]
    centre_gap = gap[..., 0] ** 2 + gap[..., 1] ** 2 + gap[..., 2] ** 2
    (bottom_a, top_a), (bottom_b, top_b) = _z_range(a), _z_range(b)
    spread_z = np.maximum(np.abs(top_a - bottom_b), np.abs(top_b - bottom_a))
    spread = _corner_spread_xy(a, b) + spread_z * spread_z
    penalty = np.divide(centre_gap, spread, out=np.zeros_like(spread), where=spread > 0.0)
    return _iou(a, b, three_d=True) - penalty.clip(0.0, 1.0)


def diou_3d(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(P, Q) DIoU of boxes a (P, 7) and b (Q, 7), in [-1, 1] (see the module docstring)."""
    return _diou(_as_boxes(a)[:, None], _as_boxes(b)[None])


def diou_3d_pairs(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """(N,) DIoU of row i of a (N, 7) with row i of b (N, 7)."""
    arr_a, arr_b = _as_boxes(a), _as_boxes(b)
    if arr_a.shape != arr_b.shape:
        raise ValueError(f"paired boxes differ in shape: {arr_a.shape} and {arr_b.shape}")
    return _diou(arr_a, arr_b)
