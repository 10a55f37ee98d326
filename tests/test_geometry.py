"""train.geometry against shapely polygons, hand-worked cases and hypothesis properties."""

import itertools
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import affinity

from train.geometry import bev_corners, bev_iou, diou_3d, diou_3d_pairs, iou_3d, iou_3d_pairs

ATOL = 1e-9


def box(x=0.0, y=0.0, z=0.0, length=1.0, width=1.0, height=1.0, yaw=0.0) -> list[float]:
    return [x, y, z, length, width, height, yaw]


def polygon(b: np.ndarray) -> shapely.Polygon:
    """The BEV rectangle built by shapely itself: an axis-aligned box turned, then moved."""
    x, y, _, length, width, _, yaw = b
    rect = shapely.box(-length / 2, -width / 2, length / 2, width / 2)
    return affinity.translate(affinity.rotate(rect, yaw, origin=(0, 0), use_radians=True), x, y)


def z_overlap(a: np.ndarray, b: np.ndarray) -> float:
    top = min(a[2] + a[5] / 2, b[2] + b[5] / 2)
    bottom = max(a[2] - a[5] / 2, b[2] - b[5] / 2)
    return max(top - bottom, 0.0)


def reference_iou(a: np.ndarray, b: np.ndarray, three_d: bool) -> np.ndarray:
    out = np.zeros((len(a), len(b)))
    for (i, ba), (j, bb) in itertools.product(enumerate(a), enumerate(b)):
        inter = polygon(ba).intersection(polygon(bb)).area
        size_a, size_b = ba[3] * ba[4], bb[3] * bb[4]
        if three_d:
            inter, size_a, size_b = inter * z_overlap(ba, bb), size_a * ba[5], size_b * bb[5]
        union = size_a + size_b - inter
        out[i, j] = inter / union if union > 0 and size_a > 0 and size_b > 0 else 0.0
    return out


def reference_diou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU_3D minus squared centre distance over the largest squared 8 x 8 corner distance."""
    out = reference_iou(a, b, three_d=True)
    for (i, ba), (j, bb) in itertools.product(enumerate(a), enumerate(b)):
        corners = []
        for bx in (ba, bb):
            ring = np.asarray(polygon(bx).exterior.coords)[:4]
            corners.append([(*c, bx[2] + s * bx[5] / 2) for c in ring for s in (-1.0, 1.0)])
        spread = max(math.dist(p, q) ** 2 for p in corners[0] for q in corners[1])
        out[i, j] -= math.dist(ba[:3], bb[:3]) ** 2 / spread
    return out


def random_boxes(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.column_stack(
        [
            rng.uniform(-2, 2, (n, 3)),
            rng.uniform(0.05, 3, (n, 3)),
            rng.uniform(-2 * np.pi, 2 * np.pi, n),
        ]
    )


def grid_boxes(rng: np.random.Generator, n: int) -> np.ndarray:
    """Boxes on a half-metre grid, yaws in multiples of pi/2: shared, collinear edges; nesting."""
    return np.column_stack(
        [
            rng.integers(-4, 5, (n, 3)) * 0.5,
            rng.integers(1, 5, (n, 3)) * 0.5,
            rng.integers(-4, 5, n) * (np.pi / 2),
        ]
    )


def turned(boxes: np.ndarray, yaw: float) -> np.ndarray:
    """Boxes turned together by yaw about the z axis."""
    out = boxes.copy()
    cos, sin = math.cos(yaw), math.sin(yaw)
    x, y = boxes[:, 0], boxes[:, 1]
    out[:, 0], out[:, 1] = cos * x - sin * y, sin * x + cos * y
    out[:, 6] += yaw
    return out


# bev_corners


def test_corners_are_counter_clockwise_and_match_hand_values():
    corners = bev_corners([box(x=1.0, y=2.0, length=4.0, width=2.0, yaw=np.pi / 2)])
    np.testing.assert_allclose(corners[0], [[0, 4], [0, 0], [2, 0], [2, 4]], atol=1e-12)
    rng = np.random.default_rng(1)
    ring = bev_corners(random_boxes(rng, 50))
    after = np.roll(ring, -1, axis=1)
    signed = 0.5 * np.sum(ring[..., 0] * after[..., 1] - ring[..., 1] * after[..., 0], axis=1)
    assert np.all(signed > 0)


# IoU against shapely


@pytest.mark.parametrize("make", [random_boxes, grid_boxes])
@pytest.mark.parametrize("three_d", [False, True])
def test_iou_matches_shapely(make, three_d):
    rng = np.random.default_rng(7)
    a, b = make(rng, 30), make(rng, 30)
    b[::3, 6] = a[::3, 6] + rng.integers(-4, 5, 10) * (np.pi / 2)  # collinear edges
    b[::4, :3] = a[::4, :3]  # shared centres
    expected = reference_iou(a, b, three_d)
    got = iou_3d(a, b) if three_d else bev_iou(a, b)
    np.testing.assert_allclose(got, expected, rtol=0, atol=ATOL)
    assert np.count_nonzero(expected) > 30  # the cases overlap, not only miss


def test_pairs_are_the_diagonal_of_the_matrix():
    rng = np.random.default_rng(3)
    a, b = grid_boxes(rng, 40), grid_boxes(rng, 40)
    np.testing.assert_array_equal(iou_3d_pairs(a, b), np.diag(iou_3d(a, b)))
    np.testing.assert_array_equal(diou_3d_pairs(a, b), np.diag(diou_3d(a, b)))
    for pairs in (iou_3d_pairs, diou_3d_pairs):
        with pytest.raises(ValueError):
            pairs(a, b[:3])


def test_identical_boxes_give_one():
    rng = np.random.default_rng(11)
    boxes = np.concatenate([random_boxes(rng, 40), grid_boxes(rng, 40)])
    boxes[:10, :2] += 50.0  # far from the origin, as on a pitch
    for fn in (bev_iou, iou_3d, diou_3d):
        np.testing.assert_allclose(np.diag(fn(boxes, boxes)), 1.0, rtol=0, atol=ATOL)


@pytest.mark.parametrize("yaw", [0.0, 0.3, np.pi / 2, 2.0])
@pytest.mark.parametrize(
    ("first", "second", "expected"),
    [
        (box(length=2), box(x=2, length=2), 0.0),  # side by side, one edge shared
        (box(), box(x=1, y=1), 0.0),  # one corner shared
        (box(length=2), box(x=0.5), 0.5),  # half of it, three edges shared
        (box(length=2, width=2), box(x=0.5, y=0.5), 0.25),  # a quarter, two edges shared
        (box(length=4, width=4), box(x=0.3, y=-0.2), 1 / 16),  # nested
        (box(), box(x=0.5), 1 / 3),  # half-shifted: two edges collinear
        (box(), box(x=5), 0.0),  # disjoint
        (box(length=2, width=1), box(length=2, width=1, yaw=np.pi), 1.0),  # turned 180 degrees
        (box(length=2, width=1), box(length=1, width=2, yaw=np.pi / 2), 1.0),  # the same box
        (box(), box(yaw=np.pi / 2), 1.0),  # square turned 90 degrees
        (box(length=3), box(length=3, yaw=-np.pi / 2), 1 / 5),  # a cross
        (box(length=1e-4, width=1e-4), box(x=5e-5, length=1e-4, width=1e-4), 1 / 3),  # tiny
    ],
)
def test_hand_cases(first, second, expected, yaw):
    a, b = turned(np.array([first]), yaw), turned(np.array([second]), yaw)
    for fn in (bev_iou, iou_3d):
        assert fn(a, b)[0, 0] == pytest.approx(expected, abs=ATOL)
        assert fn(b, a)[0, 0] == pytest.approx(expected, abs=ATOL)


def test_boxes_touching_vertically_do_not_overlap():
    a, b = np.array([box()]), np.array([box(z=1.0)])
    assert iou_3d(a, b)[0, 0] == 0.0
    assert bev_iou(a, b)[0, 0] == 1.0
    assert iou_3d(a, np.array([box(z=0.5)]))[0, 0] == pytest.approx(1 / 3, abs=ATOL)


def test_zero_size_boxes_give_zero_not_nan():
    flat = [box(length=0.0), box(width=0.0), box(height=0.0), box(length=0, width=0, height=0)]
    boxes = np.array(flat + [box()])
    for fn in (bev_iou, iou_3d, diou_3d):
        out = fn(boxes, boxes)
        assert np.all(np.isfinite(out))
    assert np.all(bev_iou(boxes, boxes)[:2] == 0.0)
    assert np.all(iou_3d(boxes, boxes)[:4] == 0.0)
    assert diou_3d(boxes[3:4], boxes[3:4])[0, 0] == 0.0  # two points at one place


def test_empty_inputs_give_empty_results():
    empty, one = np.zeros((0, 7)), np.array([box()])
    assert bev_iou(empty, one).shape == (0, 1)
    assert iou_3d(one, empty).shape == (1, 0)
    assert diou_3d(empty, empty).shape == (0, 0)
    assert iou_3d_pairs(empty, empty).shape == (0,)
    with pytest.raises(ValueError):
        bev_iou(np.zeros((2, 6)), one)


# DIoU


def test_diou_hand_cases():
    cube = np.array([box()])
    assert diou_3d(cube, cube)[0, 0] == pytest.approx(1.0, abs=ATOL)
    # Unit cubes 2 m apart along x: IoU 0, centres 2 m apart, farthest corners sqrt(3^2 + 1 + 1).
    assert diou_3d(cube, np.array([box(x=2.0)]))[0, 0] == pytest.approx(-4 / 11, abs=ATOL)


@pytest.mark.parametrize("make", [random_boxes, grid_boxes])
def test_diou_matches_brute_force(make):
    rng = np.random.default_rng(5)
    a, b = make(rng, 12), make(rng, 12)
    np.testing.assert_allclose(diou_3d(a, b), reference_diou(a, b), rtol=0, atol=ATOL)


# Properties

coordinate = st.floats(-5, 5, allow_nan=False)
solid_size = st.one_of(st.floats(1e-3, 4), st.sampled_from([0.5, 1.0, 2.0]))
size = st.one_of(st.just(0.0), solid_size)
yaw = st.one_of(
    st.floats(-2 * np.pi, 2 * np.pi, allow_nan=False),
    st.integers(-4, 4).map(lambda k: k * np.pi / 2),
)


def box_arrays(side: st.SearchStrategy[float] = size) -> st.SearchStrategy[np.ndarray]:
    one_box = st.tuples(coordinate, coordinate, coordinate, side, side, side, yaw)
    return st.lists(one_box, min_size=1, max_size=6).map(np.array)


PROPERTY = settings(max_examples=150, deadline=None)


@PROPERTY
@given(box_arrays(), box_arrays())
def test_symmetry_and_bounds(a, b):
    for fn in (bev_iou, iou_3d):
        ab, ba = fn(a, b), fn(b, a)
        np.testing.assert_allclose(ab, ba.T, rtol=0, atol=ATOL)
        assert np.all((ab >= 0) & (ab <= 1))
    diou = diou_3d(a, b)
    np.testing.assert_allclose(diou, diou_3d(b, a).T, rtol=0, atol=ATOL)
    assert np.all((diou >= -1) & (diou <= 1))
    np.testing.assert_allclose(iou_3d_pairs(a, a[::-1]), np.diag(iou_3d(a, a[::-1])))


@PROPERTY
@given(box_arrays())
def test_identity(a):
    has_volume = (a[:, 3] > 0) & (a[:, 4] > 0) & (a[:, 5] > 0)
    np.testing.assert_allclose(np.diag(iou_3d(a, a)), has_volume.astype(float), rtol=0, atol=ATOL)
    np.testing.assert_allclose(np.diag(diou_3d(a, a)), has_volume.astype(float), rtol=0, atol=ATOL)


@PROPERTY
@given(
    box_arrays(solid_size),  # DIoU jumps where zero-size boxes meet: tested apart
    box_arrays(solid_size),
    st.floats(-np.pi, np.pi),
    st.tuples(*[st.floats(-60, 60)] * 3),
)
def test_invariant_under_common_rotation_and_translation(a, b, angle, shift):
    def move(boxes: np.ndarray) -> np.ndarray:
        out = turned(boxes, angle)
        out[:, :3] += shift
        return out

    for fn in (bev_iou, iou_3d, diou_3d):
        np.testing.assert_allclose(fn(move(a), move(b)), fn(a, b), rtol=0, atol=1e-8)
