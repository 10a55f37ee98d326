"""The static scene: goals with nets and, optionally, advertising boards and a stand.

Triangle meshes built once per scenario (trimesh primitives), each face with a semantic class,
a reflectivity at 905 nm and a transmission (the fraction of rays a goal net lets through).
The ground and its painted lines are analytic (`simgen.scene.pitch`); players are `simgen.body.mesh`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from simgen.scene.pitch import HALF_LENGTH_M, HALF_WIDTH_M
from simgen.vocab import GOAL, SURROUNDINGS

# Reflectivities at 905 nm (assumptions): grass ~0.35 (vegetation reflects 0.3-0.5 in the near
# infrared), white paint 0.8, white goal frame 0.8, nylon net 0.5, boards 0.6, concrete stand 0.3.
GRASS_REFLECTIVITY = 0.35
LINE_REFLECTIVITY = 0.8
BALL_REFLECTIVITY = 0.7
BALL_RADIUS_M = 0.11
GOAL_HALF_WIDTH_M = 3.66  # inner edges of the posts
GOAL_HEIGHT_M = 2.44  # underside of the crossbar
POST_DIAMETER_M = 0.12
NET_DEPTH_M = 2.0


@dataclass(frozen=True)
class StaticScene:
    """Static triangles in the pitch frame (metres) with per-face attributes."""

    vertices: NDArray[np.float32]  # (V, 3)
    faces: NDArray[np.int32]  # (F, 3)
    semantic: NDArray[np.uint8]  # (F,) index into simgen.vocab.SEMANTIC_NAMES
    reflectivity: NDArray[np.float32]  # (F,) 0..1
    transmission: NDArray[np.float32]  # (F,) fraction of rays passing through (nets), 0 for solids


def _cylinder(start, end, radius: float) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([start, end], dtype=float), sections=12)


def _panel(corner, edge_a, edge_b) -> trimesh.Trimesh:
    """A flat two-triangle quad (nets: rays hit it from either side)."""
    corner, edge_a, edge_b = (np.asarray(v, dtype=float) for v in (corner, edge_a, edge_b))
    vertices = [corner, corner + edge_a, corner + edge_a + edge_b, corner + edge_b]
    return trimesh.Trimesh(vertices=vertices, faces=[[0, 1, 2], [0, 2, 3]], process=False)


def _box(centre, extents) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=extents, transform=trimesh.transformations.translation_matrix(centre))


def goal_meshes(side: float) -> tuple[list[trimesh.Trimesh], list[trimesh.Trimesh]]:
    """(frame, net) of the goal on the goal line x = side * 52.5 (side is -1 or +1)."""
    x = side * HALF_LENGTH_M
    r = POST_DIAMETER_M / 2
    y_post = GOAL_HALF_WIDTH_M + r
    top = GOAL_HEIGHT_M + r
    frame = [
        _cylinder((x, -y_post, 0), (x, -y_post, top + r), r),
        _cylinder((x, y_post, 0), (x, y_post, top + r), r),
        _cylinder((x, -y_post, top), (x, y_post, top), r),
    ]
    back = x + side * NET_DEPTH_M
    depth = back - x
    net = [
        _panel((back, -y_post, 0), (0, 2 * y_post, 0), (0, 0, top)),  # back
        _panel((x, -y_post, top), (depth, 0, 0), (0, 2 * y_post, 0)),  # roof
        _panel((x, -y_post, 0), (depth, 0, 0), (0, 0, top)),  # sides
        _panel((x, y_post, 0), (depth, 0, 0), (0, 0, top)),
    ]
    return frame, net


def surroundings_meshes(board_offset_m: float = 4.0, stand_rows: int = 12) -> list[trimesh.Trimesh]:
    """Advertising boards (0.9 m tall) round the pitch and a stepped stand behind the far touchline."""
    height, thickness = 0.9, 0.05
    bx, by = HALF_LENGTH_M + board_offset_m, HALF_WIDTH_M + board_offset_m
    boards = [
        _box((0, by, height / 2), (2 * bx, thickness, height)),
        _box((0, -by, height / 2), (2 * bx, thickness, height)),
        _box((bx, 0, height / 2), (thickness, 2 * by, height)),
        _box((-bx, 0, height / 2), (thickness, 2 * by, height)),
    ]
    row_depth, row_rise = 0.8, 0.4
    stand = [
        _box(
            (0, by + 2.0 + (row + 0.5) * row_depth, (row + 1) * row_rise / 2), (2 * bx, row_depth, (row + 1) * row_rise)
        )
        for row in range(stand_rows)
    ]
    return boards + stand


def build_static_scene(goals: bool = True, surroundings: bool = False, net_transmission: float = 0.7) -> StaticScene:
    """The static triangles of a scenario's scene."""
    parts: list[tuple[trimesh.Trimesh, int, float, float]] = []
    if goals:
        for side in (-1.0, 1.0):
            frame, net = goal_meshes(side)
            parts += [(mesh, GOAL, 0.8, 0.0) for mesh in frame]
            parts += [(mesh, GOAL, 0.5, net_transmission) for mesh in net]
    if surroundings:
        parts += [(mesh, SURROUNDINGS, 0.6 if i < 4 else 0.3, 0.0) for i, mesh in enumerate(surroundings_meshes())]
    if not parts:
        empty = np.zeros((0, 3))
        return StaticScene(
            empty.astype(np.float32),
            empty.astype(np.int32),
            *(np.zeros(0, t) for t in (np.uint8, np.float32, np.float32)),
        )
    offsets = np.cumsum([0] + [len(mesh.vertices) for mesh, *_ in parts])
    counts = [len(mesh.faces) for mesh, *_ in parts]
    return StaticScene(
        vertices=np.concatenate([mesh.vertices for mesh, *_ in parts]).astype(np.float32),
        faces=np.concatenate([mesh.faces + offset for (mesh, *_), offset in zip(parts, offsets)]).astype(np.int32),
        semantic=np.repeat([p[1] for p in parts], counts).astype(np.uint8),
        reflectivity=np.repeat([p[2] for p in parts], counts).astype(np.float32),
        transmission=np.repeat([p[3] for p in parts], counts).astype(np.float32),
    )
