"""A run's state inside its output directory (`.simgen/`): the lock, the scenario it was started
with, each clip's captured motion and shard plan, and the markers of done shards and clips (each
written last, atomically, so that `--resume` trusts what it finds)."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
from pathlib import Path

from simgen.atomic import atomic_path
from simgen.errors import UserError
from simgen.scenario import Scenario

WORK_DIR = ".simgen"  # run state inside the output directory; removed when the dataset is finished
CARD_NAME = "README.md"  # simgen.datasets.write.CARD_NAME (not imported: workers import this module light)


def _state(root: Path, *parts: str) -> Path:
    return root / WORK_DIR / Path(*parts)


def motion_path(root: Path, clip_index: int) -> Path:
    return _state(root, "motion", f"{clip_index:04d}")


def plan_path(root: Path, clip_index: int) -> Path:
    return _state(root, "motion", f"{clip_index:04d}.json")


def shard_marker(root: Path, clip_index: int, first: int) -> Path:
    return _state(root, "shards", f"{clip_index:04d}", f"{first:06d}.json")


def shard_root(root: Path, clip_index: int, first: int) -> Path:
    """Where a shard writes its partial Parquet clip."""
    return _state(root, "shards", f"{clip_index:04d}", f"{first:06d}")


def clip_marker(root: Path, clip_index: int) -> Path:
    return _state(root, "clips", f"{clip_index:04d}.json")


def write_json(path: Path, data) -> None:
    """A plan or a marker, written atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, sort_keys=True))


def read_plan(root: Path, clip_index: int) -> dict:
    """A captured clip's plan: {"frames", "shards": [[first, stop], ...]}."""
    return json.loads(plan_path(root, clip_index).read_text())


def clean_clip(root: Path, clip_index: int) -> None:
    """Remove the run state of a done clip: its motion and shards are no longer needed."""
    shutil.rmtree(_state(root, "shards", f"{clip_index:04d}"), ignore_errors=True)
    shutil.rmtree(motion_path(root, clip_index), ignore_errors=True)
    plan_path(root, clip_index).unlink(missing_ok=True)


def done_clips(root: Path) -> dict[int, dict]:
    """Clips recorded as finished by an earlier (interrupted) run."""
    records = {}
    for marker in sorted(_state(root, "clips").glob("*.json")):
        record = json.loads(marker.read_text())
        records[record["clip_index"]] = record
    return records


class OutputLock:
    """An exclusive lock on an output directory, held for the whole run (released if we die)."""

    def __init__(self, root: Path):
        (root / WORK_DIR).mkdir(parents=True, exist_ok=True)
        self._file = open(root / WORK_DIR / "lock", "a+")
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.seek(0)
            holder = self._file.read().strip() or "another process"
            self._file.close()
            raise UserError(
                f"{root}: another simgen generate is writing here ({holder}); wait for it or use another -o"
            ) from None
        self._file.seek(0)
        self._file.truncate()
        self._file.write(f"pid {os.getpid()} on {os.uname().nodename}")
        self._file.flush()

    def release(self) -> None:
        fcntl.flock(self._file, fcntl.LOCK_UN)
        self._file.close()


def prepare_output(root: Path, scenario: Scenario, resume: bool, overwrite: bool) -> bool:
    """Check the output directory against --resume/--overwrite; record the scenario for resumes.

    True: a resumed run whose manifest is already written (only the card or the cleanup is left)."""
    state = root / WORK_DIR / "scenario.json"
    resolved = json.dumps(scenario.model_dump(mode="json"), sort_keys=True)
    complete = (root / "manifest.json").exists()
    interrupted = state.exists()
    occupied = complete or interrupted or any(child.name != WORK_DIR for child in root.iterdir())
    if overwrite and occupied:
        if not (complete or interrupted):
            raise UserError(f"{root}: not a simgen dataset; refusing to delete it with --overwrite")
        for child in root.iterdir():
            if child.name != WORK_DIR:
                shutil.rmtree(child) if child.is_dir() else child.unlink()
        for kind in ("clips", "motion", "shards"):
            shutil.rmtree(root / WORK_DIR / kind, ignore_errors=True)
    elif resume and occupied:
        if complete and not interrupted and (root / CARD_NAME).exists():
            raise UserError(f"{root}: the dataset is already complete (manifest.json); nothing to resume")
        if not (complete or interrupted):
            raise UserError(f"{root}: holds files but no interrupted simgen generate run to resume")
        if interrupted and state.read_text() != resolved:
            raise UserError(
                f"{root}: was started with another scenario or options; resume with the same ones, or --overwrite"
            )
        for leftover in root.rglob("*.tmp-*"):  # files an interrupted writer never renamed
            leftover.unlink()
        if complete:
            return True
    elif occupied and not overwrite:
        raise UserError(
            f"{root}: already exists; use --resume to finish an interrupted run or --overwrite to replace it"
        )
    (root / WORK_DIR / "clips").mkdir(parents=True, exist_ok=True)
    with atomic_path(state) as tmp:
        tmp.write_text(resolved)
    return False
