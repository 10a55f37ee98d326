"""What the renderer keeps over a clip: the static scene's casters, the bodies' part templates, and
their poses per time slice (at most 10 ms; slices tile the clip from its first captured time).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simgen.body.mesh import REFLECTIVITY, part_frames, part_templates
from simgen.motion.clip import MotionClip
from simgen.motion.interpolate import interpolate_clip
from simgen.render.raycast import PartCaster, StaticCaster
from simgen.scene.static import StaticScene
from simgen.vocab import GOAL, KEYPOINT_INDEX, OFFICIAL, PLAYER, SURROUNDINGS

SLICE_S = 0.01  # longest time over which a humanoid keeps one pose within a sweep
POSE_CHUNK_SLICES = 50  # slices posed at once (0.5 s); the World keeps two such chunks


@dataclass(frozen=True)
class SlicePoses:
    """Humanoids and the ball at S consecutive time slices, the first being slice `first` of the clip."""

    first: int
    middle_m: NDArray[np.float64]  # (S, H, 3) each humanoid's `middle` keypoint
    reach_m: NDArray[np.float64]  # (S, H) radius round `middle` of a sphere holding the body
    ball_m: NDArray[np.float64]  # (S, 3)
    rotation: NDArray[np.float64]  # (S, H, P, 3, 3) part -> pitch coordinates (simgen.body.mesh.part_frames)
    translation_m: NDArray[np.float64]  # (S, H, P, 3)

    def __getitem__(self, index: slice) -> SlicePoses:
        start = index.start or 0
        return SlicePoses(
            self.first + start,
            self.middle_m[index],
            self.reach_m[index],
            self.ball_m[index],
            self.rotation[index],
            self.translation_m[index],
        )


class World:
    """What stays the same over a clip: the static scene, and every humanoid's rigid part meshes."""

    def __init__(self, clip: MotionClip, scene: StaticScene):
        self.clip = clip
        self.scene = scene
        self.static = StaticCaster(scene.vertices, scene.faces)
        templates = part_templates(clip.keypoints_m[0].astype(np.float64), clip.team)
        # One template per (part, humanoid): template p * H + h.
        self.num_parts = len(templates)
        self.parts = PartCaster([(local[h], faces) for local, faces, _ in templates for h in range(clip.num_humanoids)])
        self.face_reflectivity = np.concatenate([REFLECTIVITY[materials].reshape(-1) for _, _, materials in templates])
        # Parts' bounding spheres in part coordinates, (H, P, 3) and (H, P).
        self.part_centre_m = self.parts.bounds.centre.reshape(self.num_parts, clip.num_humanoids, 3).swapaxes(0, 1)
        self.part_radius_m = self.parts.bounds.radius.reshape(self.num_parts, clip.num_humanoids).T
        self.semantic = np.where(clip.team == "official", OFFICIAL, PLAYER).astype(np.uint8)
        # Goals are small seen from a sensor: only rays through their bounding spheres are cast at
        # them. Boards and a stand surround the sensor: with them, every ray is cast.
        self.cast_all_static = bool((scene.semantic == SURROUNDINGS).any())
        spheres = []
        for side in (-1.0, 1.0):
            faces = scene.faces[(scene.semantic == GOAL) & (np.sign(scene.vertices[scene.faces[:, 0], 0]) == side)]
            if len(faces):
                vertices = scene.vertices[faces.reshape(-1)].astype(np.float64)
                centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
                spheres.append((*centre, np.linalg.norm(vertices - centre, axis=1).max() + 1e-3))
        self.static_spheres = np.array(spheres, dtype=np.float64).reshape(-1, 4)
        self.num_slices = int(np.floor((clip.time_s[-1] - clip.time_s[0]) / SLICE_S)) + 1
        self._chunks: dict[int, SlicePoses] = {}

    def slice_index(self, time_s: NDArray) -> NDArray[np.int64]:
        """The clip's time slice of each time (s), clamped to the clip."""
        index = np.floor((np.asarray(time_s) - self.clip.time_s[0]) / SLICE_S).astype(np.int64)
        return np.clip(index, 0, self.num_slices - 1)

    def poses(self, first: int, count: int) -> SlicePoses:
        """Poses of slices first .. first + count - 1, each at its middle (clamped to the clip)."""
        parts = []
        for chunk in range(first // POSE_CHUNK_SLICES, (first + count - 1) // POSE_CHUNK_SLICES + 1):
            poses = self._chunk(chunk)
            start = max(first - poses.first, 0)
            parts.append(poses[start : first + count - poses.first])
        if len(parts) == 1:
            return parts[0]
        columns = zip(*((p.middle_m, p.reach_m, p.ball_m, p.rotation, p.translation_m) for p in parts))
        return SlicePoses(first, *(np.concatenate(column) for column in columns))

    def _chunk(self, chunk: int) -> SlicePoses:
        if chunk not in self._chunks:
            if len(self._chunks) >= 2:
                del self._chunks[min(self._chunks)]
            first = chunk * POSE_CHUNK_SLICES
            count = min(POSE_CHUNK_SLICES, self.num_slices - first)
            self._chunks[chunk] = self._posed(first, self.clip.time_s[0] + (first + np.arange(count) + 0.5) * SLICE_S)
        return self._chunks[chunk]

    def pose_at(self, time_s: float) -> SlicePoses:
        """Everything posed at one instant (s), as one slice (`first` 0): a frame cast as a snapshot."""
        return self._posed(0, np.array([time_s]))

    def _posed(self, first: int, times_s: NDArray) -> SlicePoses:
        """Humanoids and ball posed at times (S,) (clamped to the clip), as slices first .. first + S - 1."""
        keypoints, ball = interpolate_clip(self.clip, np.clip(times_s, self.clip.time_s[0], self.clip.time_s[-1]))
        rotation, translation = part_frames(keypoints.reshape(-1, 12, 3))
        shape = (len(times_s), self.clip.num_humanoids, self.num_parts)
        rotation, translation = rotation.reshape(shape + (3, 3)), translation.reshape(shape + (3,))
        # Each body's bounding sphere round `middle`: its parts' spheres, as posed.
        middle = keypoints[:, :, KEYPOINT_INDEX["middle"]]
        centres = np.einsum("shpij,hpj->shpi", rotation, self.part_centre_m) + translation
        reach = (np.linalg.norm(centres - middle[:, :, None], axis=3) + self.part_radius_m).max(axis=2)
        return SlicePoses(first, middle, reach, ball, rotation, translation)
