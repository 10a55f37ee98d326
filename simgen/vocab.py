"""Names and ids every stage shares: keypoints, teams, roles, classes, semantic classes, the ball's id.

Pitch frame (used everywhere in simgen): origin at the centre spot, x along the touchline
towards the right team's goal, y to the left (seen from the left goal looking at the right
one), z up; metres. The pitch is 105 m x 68 m: x in [-52.5, 52.5], y in [-34, 34].
"""

# The engine's 12-part humanoid skeleton, in the order the engine exports it.
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

TEAM_NAMES = ("left", "right", "official")  # MotionClip.team values: the two teams, then the officials
ROLE_NAMES = ("GK", "CB", "LB", "RB", "DM", "CM", "LM", "RM", "AM", "CF")  # players' roles in the engine
OFFICIAL_ROLES = ("referee", "linesman", "linesman")
PLAYERS_PER_TEAM = 11  # players the engine puts on the pitch per team (`playerNum`, gfootball_engine gamedefines.hpp)
MAX_HUMANOIDS = 2 * PLAYERS_PER_TEAM + len(OFFICIAL_ROLES)  # on a pitch at once: 25, so at most 25 boxes a frame

PLAYER_CLASS = "Pedestrian"  # KITTI's class for people on foot, as KITTI-trained detectors expect
OFFICIAL_CLASS = "Official"  # referee and linesmen: people, but not players
CLASS_NAMES = (PLAYER_CLASS, OFFICIAL_CLASS)

# Semantic class of a point: its index in SEMANTIC_NAMES.
SEMANTIC_NAMES = ("ground", "line", "player", "official", "ball", "goal", "surroundings")
GROUND, LINE, PLAYER, OFFICIAL, BALL, GOAL, SURROUNDINGS = range(len(SEMANTIC_NAMES))

BALL_INSTANCE_ID = 1000  # instance id of the ball's points (humanoids: their track id; anything else: -1)
