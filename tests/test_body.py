"""Humanoid meshes: closed parts, adult sizes, materials, rigid motion, robustness."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from simgen.body.mesh import (
    GARMENT_NAMES,
    MATERIAL_NAMES,
    NUM_FACES,
    NUM_VERTICES,
    PART_NAMES,
    REFLECTIVITY,
    body_extent,
    body_meshes,
    part_frames,
    part_templates,
)
from simgen.vocab import KEYPOINT_INDEX as I
from simgen.vocab import TEAM_NAMES
from tests.support.poses import PRESETS, keypoints, lying_keypoints, random_pose


def _poses(count: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    poses = list(PRESETS.values()) + [random_pose(rng) for _ in range(count)]
    return np.stack([keypoints(p, rng.uniform(-np.pi, np.pi), rng.uniform(-50, 50, 2)) for p in poses])


def _materials(mesh, humanoid: int, part: str) -> set[str]:
    faces = mesh.part_id == PART_NAMES.index(part)
    return {MATERIAL_NAMES[m] for m in np.unique(mesh.material_id[humanoid, faces])}


def test_shapes_and_dtypes():
    kp = _poses(3)
    mesh = body_meshes(kp, ["left"] * len(kp))
    assert mesh.vertices_m.shape == (len(kp), NUM_VERTICES, 3) and mesh.vertices_m.dtype == np.float32
    assert mesh.vertices_m.flags.c_contiguous
    assert mesh.faces.shape == (NUM_FACES, 3) and mesh.faces.dtype == np.int32
    assert mesh.faces.min() == 0 and mesh.faces.max() == NUM_VERTICES - 1
    assert mesh.part_id.shape == (NUM_FACES,) and mesh.material_id.shape == (len(kp), NUM_FACES)
    assert set(np.unique(mesh.part_id)) == set(range(len(PART_NAMES)))
    assert 300 <= NUM_FACES <= 1000  # a few hundred triangles per humanoid


@pytest.mark.parametrize(
    "kp", [*_poses(4), lying_keypoints()], ids=[*PRESETS, *(f"random{i}" for i in range(4)), "lying"]
)
def test_every_part_is_closed_and_wound_outward(kp):
    mesh = body_meshes(kp[None], ["right"])
    for p, name in enumerate(PART_NAMES):
        part = trimesh.Trimesh(
            mesh.vertices_m[0].astype(np.float64), mesh.faces[mesh.part_id == p], process=False
        )
        assert part.is_watertight, name
        assert part.is_winding_consistent, name
        assert part.volume > 0, name  # outward normals


def _part_vertices(mesh, humanoid: int, part: str) -> np.ndarray:
    faces = mesh.faces[mesh.part_id == PART_NAMES.index(part)]
    return mesh.vertices_m[humanoid, np.unique(faces)].astype(np.float64)


def test_standing_adult_size():
    mesh = body_meshes(keypoints(PRESETS["standing"])[None], ["left"])
    vertices = mesh.vertices_m[0].astype(np.float64)
    assert 1.7 <= vertices[:, 2].max() <= 1.9  # standing height
    assert 0.0 <= vertices[:, 2].min() <= 0.03  # soles on the ground
    assert 0.40 <= np.ptp(vertices[:, 1]) <= 0.55  # across the shoulders and arms
    volume = trimesh.Trimesh(vertices, mesh.faces, process=False).volume
    assert 0.06 <= volume <= 0.09  # m^3 (parts overlap at the joints): a 70-80 kg adult


def test_hands_and_feet_extend_the_skeleton():
    kp = keypoints(PRESETS["standing"])
    mesh = body_meshes(kp[None], ["left"])
    reach = np.linalg.norm(_part_vertices(mesh, 0, "left_forearm") - kp[I["left_elbow"]], axis=1).max()
    assert reach == pytest.approx(0.45, abs=0.01)
    foot = _part_vertices(mesh, 0, "left_foot")
    assert np.ptp(foot[:, 0]) == pytest.approx(0.265, abs=0.01)  # along the heading, +x
    assert foot[:, 0].max() > kp[I["left_ankle"], 0] + 0.15  # toes in front
    head = _part_vertices(mesh, 0, "head")
    assert head[:, 2].max() - kp[I["neck"], 2] == pytest.approx(0.26, abs=0.01)


def test_materials_follow_garments_and_teams():
    kp = np.repeat(keypoints(PRESETS["running"])[None], 3, axis=0)
    mesh = body_meshes(kp, list(TEAM_NAMES))
    for h, team in enumerate(TEAM_NAMES):
        assert _materials(mesh, h, "head") == {"skin"}
        assert _materials(mesh, h, "left_forearm") == {"skin"}
        assert _materials(mesh, h, "right_foot") == {"boots"}
        assert _materials(mesh, h, "pelvis") == {f"shorts_{team}"}
        assert _materials(mesh, h, "chest") == {f"shirt_{team}"}
        assert _materials(mesh, h, "left_upper_arm") == {f"shirt_{team}", "skin"}
        assert _materials(mesh, h, "right_thigh") == {f"shorts_{team}", "skin"}
        assert _materials(mesh, h, "left_shin") == {f"socks_{team}", "skin"}
    shirt = {team: REFLECTIVITY[MATERIAL_NAMES.index(f"shirt_{team}")] for team in TEAM_NAMES}
    assert shirt["left"] > REFLECTIVITY[MATERIAL_NAMES.index("skin")] > shirt["right"] > shirt["official"] > 0
    assert np.all((REFLECTIVITY > 0) & (REFLECTIVITY <= 1))
    assert len(GARMENT_NAMES) == 5


def test_torso_shows_the_shirt_above_the_shorts():
    kp = keypoints(PRESETS["standing"])
    mesh = body_meshes(kp[None], ["left"])
    torso = np.isin(mesh.part_id, [PART_NAMES.index("pelvis"), PART_NAMES.index("chest")])
    centre_z = mesh.vertices_m[0][mesh.faces[torso]].mean(axis=1)[:, 2]
    names = np.array(MATERIAL_NAMES)[mesh.material_id[0, torso]]
    hips_z = kp[[I["left_thigh"], I["right_thigh"]], 2].mean()
    assert np.median(centre_z[names == "shirt_left"]) > np.median(centre_z[names == "shorts_left"])
    assert centre_z[names == "shirt_left"].min() > hips_z
    assert centre_z[names == "shorts_left"].max() < kp[I["middle"], 2] + 0.15


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    yaw=st.floats(-np.pi, np.pi),
    shift=st.tuples(st.floats(-50, 50), st.floats(-30, 30)),
)
def test_mesh_moves_with_the_skeleton(seed, yaw, shift):
    pose = random_pose(np.random.default_rng(seed))
    base = body_meshes(keypoints(pose)[None], ["left"]).vertices_m[0].astype(np.float64)
    moved = body_meshes(keypoints(pose, yaw, shift)[None], ["left"]).vertices_m[0]
    c, s = np.cos(yaw), np.sin(yaw)
    expected = np.stack(
        [c * base[:, 0] - s * base[:, 1] + shift[0], s * base[:, 0] + c * base[:, 1] + shift[1], base[:, 2]],
        1,
    )
    np.testing.assert_allclose(moved, expected, atol=1e-4)  # float32 at 50 m


def test_humanoids_are_independent():
    kp = _poses(6)
    together = body_meshes(kp, ["left"] * len(kp)).vertices_m
    alone = np.stack([body_meshes(k[None], ["left"]).vertices_m[0] for k in kp])
    np.testing.assert_array_equal(together, alone)


@pytest.mark.parametrize(
    "kp",
    [
        np.zeros((12, 3)),  # collapsed skeleton
        np.tile([5.0, 5.0, 1.0], (12, 1)),
        lying_keypoints(),
        np.where(
            np.arange(12)[:, None] == I["left_shoulder"],
            keypoints(PRESETS["standing"])[I["right_shoulder"]],
            keypoints(PRESETS["standing"]),
        ),
    ],
    ids=["zeros", "one_point", "lying", "coincident_shoulders"],
)
def test_degenerate_skeletons_give_finite_meshes(kp):
    mesh = body_meshes(kp[None], ["official"])
    assert np.all(np.isfinite(mesh.vertices_m))


@pytest.mark.parametrize("kp", [*_poses(3), lying_keypoints()])
def test_body_extent_bounds_the_mesh(kp):
    rng = np.random.default_rng(1)
    directions = rng.normal(size=(1, 20, 3))
    directions /= np.linalg.norm(directions, axis=2, keepdims=True)
    low, high = body_extent(kp[None], directions)
    along = body_meshes(kp[None], ["left"]).vertices_m[0].astype(np.float64) @ directions[0].T
    assert np.all(along.min(axis=0) >= low[0] - 1e-4) and np.all(along.max(axis=0) <= high[0] + 1e-4)
    assert np.all(along.min(axis=0) - low[0] < 0.01) and np.all(high[0] - along.max(axis=0) < 0.01)


def test_bad_input_is_rejected():
    kp = keypoints(PRESETS["standing"])[None]
    with pytest.raises(ValueError, match="keypoints must have shape"):
        body_meshes(kp[:, :11], ["left"])
    with pytest.raises(ValueError, match="unknown teams"):
        body_meshes(kp, ["home"])
    with pytest.raises(ValueError, match="teams for"):
        body_meshes(kp, ["left", "right"])


def test_parts_move_rigidly_on_the_engine_skeleton(motion_clip):
    """The ray caster's premise: a part's mesh is fixed in its frame, in every captured pose."""
    kp = motion_clip.keypoints_m[::37].reshape(-1, 12, 3).astype(np.float64)
    teams = np.tile(motion_clip.team, len(kp) // motion_clip.num_humanoids)
    first = motion_clip.keypoints_m[0].astype(np.float64)
    templates = part_templates(np.tile(first, (len(kp) // len(first), 1, 1)), teams)
    rotation, origin = part_frames(kp)
    mesh = body_meshes(kp, teams)
    rebuilt = np.concatenate(
        [
            np.einsum("hij,hvj->hvi", rotation[:, p], local) + origin[:, p, None]
            for p, (local, _, _) in enumerate(templates)
        ],
        axis=1,
    )
    np.testing.assert_allclose(rebuilt, mesh.vertices_m, atol=2e-4)
    faces = np.concatenate([f + sum(len(t[0][0]) for t in templates[:p]) for p, (_, f, _) in enumerate(templates)])
    np.testing.assert_array_equal(faces, mesh.faces)
