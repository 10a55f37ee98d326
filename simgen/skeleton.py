"""The engine's 12-part humanoid skeleton, in the order the engine exports it.

Pitch frame (used everywhere in simgen): origin at the centre spot, x along the touchline
towards the right team's goal, y to the left (seen from the left goal looking at the right
one), z up; metres. The pitch is 105 m x 68 m: x in [-52.5, 52.5], y in [-34, 34].
"""

KEYPOINT_NAMES: tuple[str, ...] = (
    "middle",
    "neck",
    "left_thigh",
    "right_thigh",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
)
NUM_KEYPOINTS = len(KEYPOINT_NAMES)
KEYPOINT_INDEX = {name: i for i, name in enumerate(KEYPOINT_NAMES)}

PITCH_LENGTH_M = 105.0
PITCH_WIDTH_M = 68.0
