"""Motion capture: the real Google Research Football engine plays, we record skeletons.

All 22 players play on the engine's built-in AI (the one agent sends `builtin_ai`). Our engine
patch (engine/gfootball-keypoints.patch) records, after every 10 ms physics step, the world
positions of the 12 body parts of every humanoid and the ball; we keep every
`100 / capture_hz`-th sample. Everything here is in the pitch frame of `simgen.vocab`.

Placements are found on every physics sample, kept or not: a humanoid whose keypoints' centroid
moves more than `PLACEMENT_STEP_M` in one 10 ms step (30 m/s; the engine's sprints reach 0.106 m,
measured over 150 s of paper_x1's clip 2) was placed by the engine, and so was a ball that moves more
than `BALL_PLACEMENT_STEP_M` (100 m/s; the hardest kicks are about 35 m/s). Before a restart the
engine places 20-22 players in the same physics step, about 2 s before `game_mode` changes.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import pkgutil
from collections.abc import Callable

import numpy as np

from simgen.errors import UserError
from simgen.motion.clip import MotionClip
from simgen.scenario import MotionConfig
from simgen.vocab import NUM_KEYPOINTS, OFFICIAL_ROLES, ROLE_NAMES

ENGINE_STEP_S = 0.1
PHYSICS_STEPS_PER_ENGINE_STEP = 10
PHYSICS_STEP_S = ENGINE_STEP_S / PHYSICS_STEPS_PER_ENGINE_STEP
PLACEMENT_STEP_M = 0.3  # a humanoid's centroid moving farther in one physics step was placed
BALL_PLACEMENT_STEP_M = 1.0  # the ball moving farther in one physics step was placed
#: Scale from the engine's observation coordinates to metres (see the engine's defines.hpp).
OBSERVATION_TO_METRES = np.array([54.4, -83.6, 1.0])


def _import_engine():
    """Import gfootball without its banners (gym's deprecation notice); a missing engine is one line."""
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    try:
        with open(os.devnull, "w") as devnull, contextlib.redirect_stdout(devnull), contextlib.redirect_stderr(devnull):
            import gfootball_engine  # noqa: F401 - the compiled engine: a missing build fails here, by name
            from gfootball.env import config as gf_config
            from gfootball.env import football_action_set, football_env_core
    except ImportError as error:
        raise UserError(f"the football engine is not installed ({error}); run `make setup`") from None
    return gf_config, football_action_set, football_env_core


def engine_levels() -> list[str]:
    """The GRF levels (modules of gfootball.scenarios) of the installed engine, found without
    importing it (`simgen validate` stays fast)."""
    spec = importlib.util.find_spec("gfootball")
    if spec is None or not spec.submodule_search_locations:
        raise UserError("the football engine is not installed (no gfootball); run `make setup`")
    folders = [os.path.join(folder, "scenarios") for folder in spec.submodule_search_locations]
    return [module.name for module in pkgutil.iter_modules(folders)]


def check_level(level: str) -> None:
    """Raise `UserError` unless the installed engine offers this GRF level (scenario module)."""
    if level not in engine_levels():
        raise UserError(f"motion.level: unknown GRF level '{level}'")


class FootballEngine:
    """The live engine, one match, all players on built-in AI, stepped 100 ms at a time."""

    def __init__(self, motion: MotionConfig, seed: int, *, capture_keypoints: bool = True):
        gf_config, action_set, env_core = _import_engine()
        check_level(motion.level)
        values = {
            "level": motion.level,
            "players": ["agent:left_players=1"],
            "action_set": "v2",
            "game_engine_random_seed": int(seed),
            "physics_steps_per_frame": PHYSICS_STEPS_PER_ENGINE_STEP,
            "real_time": False,
            "render": False,
            "write_video": False,
            "dump_full_episodes": False,
            "dump_scores": False,
        }
        self._core = env_core.FootballEnvCore(gf_config.Config(values))
        self._engine = self._core._env  # the boost-python GameEnv of the patched engine
        scenario_config = self._engine.config
        if motion.left_difficulty is not None:
            scenario_config.left_team_difficulty = motion.left_difficulty
        if motion.right_difficulty is not None:
            scenario_config.right_team_difficulty = motion.right_difficulty
        self._builtin_ai = action_set.action_builtin_ai._backend_action
        self._engine.set_keypoint_capture(capture_keypoints)
        self.physics_steps = 0

    def step(self) -> None:
        """Play 100 ms of game time (10 physics steps)."""
        self._engine.perform_action(self._builtin_ai, True, 0)
        self._engine.step()
        self.physics_steps += PHYSICS_STEPS_PER_ENGINE_STEP

    def info(self):
        return self._engine.get_info()

    def samples(self) -> np.ndarray:
        """What the last step recorded: (10, H*12 + 1, 3) float32, humanoid parts then the ball."""
        raw = np.frombuffer(self._engine.get_keypoints(), dtype=np.float32)
        return raw.reshape(PHYSICS_STEPS_PER_ENGINE_STEP, -1, 3)

    def close(self) -> None:
        self._engine.set_keypoint_capture(False)
        self._core.close()


def _roster(info, num_humanoids: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n_left, n_right = len(info.left_team), len(info.right_team)
    n_officials = num_humanoids - n_left - n_right
    if not 0 <= n_officials <= len(OFFICIAL_ROLES):
        raise RuntimeError(f"engine exported {num_humanoids} humanoids for {n_left}+{n_right} players")
    team = ["left"] * n_left + ["right"] * n_right + ["official"] * n_officials
    roles = [ROLE_NAMES[int(p.role)] for p in info.left_team]
    roles += [ROLE_NAMES[int(p.role)] for p in info.right_team]
    roles += list(OFFICIAL_ROLES[:n_officials])
    return np.arange(num_humanoids, dtype=np.int32), np.array(team), np.array(roles)


def _engine_positions(info, num_humanoids: int) -> np.ndarray:
    """The engine's own reported player positions, converted to the pitch frame (metres)."""
    out = np.full((num_humanoids, 3), np.nan, dtype=np.float32)
    players = list(info.left_team) + list(info.right_team)
    for i, player in enumerate(players):
        out[i] = [player.position[k] for k in range(3)] * OBSERVATION_TO_METRES
    return out


class _Placements:
    """Finds placements sample by sample; what it found since the last kept frame waits for that frame."""

    def __init__(self, num_humanoids: int):
        self.centroid = self.ball = None  # at the previous physics sample
        self.humanoids = np.full(num_humanoids, np.nan)  # first placement time since the last kept frame
        self.ball_time = np.nan

    def see(self, time_s: float, keypoints: np.ndarray, ball: np.ndarray) -> None:
        """One physics sample: keypoints (H, 12, 3) and ball (3,) at `time_s`."""
        centroid = keypoints.mean(axis=1)
        if self.centroid is not None:
            jumped = np.linalg.norm(centroid - self.centroid, axis=1) > PLACEMENT_STEP_M
            self.humanoids[jumped & np.isnan(self.humanoids)] = time_s
            if np.isnan(self.ball_time) and np.linalg.norm(ball - self.ball) > BALL_PLACEMENT_STEP_M:
                self.ball_time = time_s
        self.centroid, self.ball = centroid, ball

    def take(self) -> tuple[np.ndarray, float]:
        """Placements since the last kept frame (humanoids (H,), ball), cleared for the next."""
        found = self.humanoids.copy(), self.ball_time
        self.humanoids[:] = np.nan
        self.ball_time = np.nan
        return found


def capture_motion(
    motion: MotionConfig, seed: int, progress: Callable[[int], None] | None = None
) -> MotionClip:
    """Play the level and capture `motion.frames` frames; `progress(n)` is told of each new frame.

    A frame is taken after every physics step whose count since kick-off is a multiple of
    `100 / capture_hz`; `time_s` is that count times 10 ms. Placements are looked for at every
    physics step from the first frame on (module docstring).
    """
    stride = round(100 / motion.capture_hz)
    engine = FootballEngine(motion, seed)
    times = np.empty(motion.frames, np.float64)
    ball = np.empty((motion.frames, 3), np.float32)
    game_mode = np.empty(motion.frames, np.int8)
    ball_placed = np.empty(motion.frames, np.float64)
    keypoints = positions = placed = placements = None  # (F, H, 12, 3), (F, H, 3), (F, H): allocated once H is known
    count = 0
    try:
        for _ in range(round(motion.skip_s / ENGINE_STEP_S)):
            engine.step()
        while count < motion.frames:
            step_start = engine.physics_steps
            engine.step()
            samples = engine.samples()
            info = engine.info()
            num_humanoids = (samples.shape[1] - 1) // NUM_KEYPOINTS
            if keypoints is None:  # filled in place: no per-frame arrays to stack at the end
                keypoints = np.empty((motion.frames, num_humanoids, NUM_KEYPOINTS, 3), np.float32)
                positions = np.empty((motion.frames, num_humanoids, 3), np.float32)
                placed = np.empty((motion.frames, num_humanoids), np.float64)
                placements = _Placements(num_humanoids)
            for sub in range(PHYSICS_STEPS_PER_ENGINE_STEP):
                physics_step = step_start + sub + 1
                sample = samples[sub, :-1].reshape(num_humanoids, NUM_KEYPOINTS, 3)
                placements.see(round(physics_step * PHYSICS_STEP_S, 6), sample, samples[sub, -1])
                if physics_step % stride or count == motion.frames:
                    continue
                times[count] = physics_step * PHYSICS_STEP_S
                keypoints[count] = sample
                ball[count] = samples[sub, -1]
                placed[count], ball_placed[count] = placements.take()
                game_mode[count] = int(info.game_mode)
                at_step_end = sub == PHYSICS_STEPS_PER_ENGINE_STEP - 1
                positions[count] = _engine_positions(info, num_humanoids) if at_step_end else np.nan
                count += 1
                if progress:
                    progress(1)
        track_id, team, role = _roster(info, num_humanoids)
    finally:
        engine.close()
    placed[0], ball_placed[0] = np.nan, np.nan  # the first frame has no frame before it to jump from
    return MotionClip(
        time_s=np.round(times, 6),
        keypoints_m=keypoints,
        ball_m=ball,
        engine_position_m=positions,
        track_id=track_id,
        team=team,
        role=role,
        jersey=np.full(len(track_id), -1, dtype=np.int16),
        capture_hz=motion.capture_hz,
        metadata={"level": motion.level, "seed": seed, **engine_versions()},
        placed_s=placed,
        ball_placed_s=ball_placed,
        game_mode=game_mode,
    )


def engine_versions() -> dict:
    """gfootball's version and the hash of our engine patch, for manifests."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        gfootball_version = version("gfootball")
    except PackageNotFoundError:
        gfootball_version = "not installed"
    return {"gfootball": gfootball_version, "engine_patch": engine_patch_hash()}


def engine_patch_hash() -> str:
    """First 12 hex digits of the sha256 of the installed engine patch (the set-up cache key)."""
    import glob
    import sys

    markers = glob.glob(os.path.join(sys.prefix, ".gfootball-*"))
    return os.path.basename(markers[0]).split("-")[-1] if markers else "unknown"
