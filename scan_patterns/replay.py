"""`replay`: a recorded pattern file (Livox's official npz or CSV) replayed with continuous time.

A file holds N shots dt apart, the first at t_first (Livox: dt = 10 us, t_first = dt, N = 400,000).
With L lasers interleaved (row i is laser i mod L; Avia: 6), a shot of laser l at time t lies at the
file position u = (t - t_first) / dt, between that laser's own rows l + L j: j = (u - l) / L, taken
mod N // L. Fractional positions (density other than x1, a head time offset) interpolate linearly
between the laser's neighbouring rows, never across lasers. The file is a loop of (N - N mod L) dt
seconds that jumps at its seam; every window that needs a shot past the file's last one (or before
its first) raises a `PatternLoopWarning`.
"""

from __future__ import annotations

import functools
import os
import stat
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from scan_patterns.livox_tables import TABLES
from scan_patterns.shots import Shots, dirs_from_livox, make_shots

# Livox's official files, shipped in scan_patterns/reference/ (its README: source, licence): Mid-40
# and Mid-70 whole (float64 degrees and times), the others as `write_tables` writes them.
OFFICIAL_FILES = {
    "mid40": "mid40_official_4s.npz",
    "mid70": "mid70_official_4s.npz",
    **{name: table.file_name(full=False) for name, table in TABLES.items()},
}


_EPS = 1e-6  # positions within this many shots of a file shot are that shot
MAX_PATTERN_BYTES = 64 << 20  # a pattern file, and an .npz's members once decompressed (Livox's: 9.6 MB)
PATTERN_SUFFIXES = (".npz", ".csv")


class PatternFileNotFound(ValueError):
    """A pattern file (official or given) is not where it was looked for."""


class PatternLoopWarning(UserWarning):
    """A replayed pattern file ran out and started again: the pattern repeats and jumps at the seam."""


@dataclass(frozen=True)
class PatternFile:
    """A recorded pattern: shot times and head-frame unit directions (float64)."""

    name: str
    t_s: NDArray[np.float64]
    dirs: NDArray[np.float64]
    lasers: int | None = None  # lasers interleaved (row i is laser i mod lasers), if the file says

    @property
    def dt_s(self) -> float:
        return float((self.t_s[-1] - self.t_s[0]) / (len(self.t_s) - 1))

    @property
    def duration_s(self) -> float:
        return len(self.t_s) * self.dt_s

    @functools.cached_property
    def columns32(self) -> NDArray[np.float32]:
        """(3, N) float32 copy of `dirs`, one row per axis: fast to gather from."""
        return np.ascontiguousarray(self.dirs.T, np.float32)


def livox_dir() -> Path:
    """Folder of the official files: $SIMGEN_LIVOX_DIR, else scan_patterns/reference (shipped)."""
    env = os.environ.get("SIMGEN_LIVOX_DIR")
    if env:
        return Path(env)
    return Path(__file__).resolve().parent / "reference"


def resolve(source: str) -> Path:
    """Path of a pattern file: an official name (`OFFICIAL_FILES`) or a path to .npz / .csv. In
    $SIMGEN_LIVOX_DIR a whole table written by `write_tables --full` comes before the excerpt."""
    path = Path(source)
    if source in OFFICIAL_FILES:
        path = livox_dir() / OFFICIAL_FILES[source]
        if source in TABLES and (livox_dir() / TABLES[source].file_name(full=True)).is_file():
            path = livox_dir() / TABLES[source].file_name(full=True)
    if not path.is_file():
        hint = " (set by $SIMGEN_LIVOX_DIR)" if source in OFFICIAL_FILES and os.environ.get("SIMGEN_LIVOX_DIR") else ""
        raise PatternFileNotFound(f"pattern file not found: {path}{hint}")
    check_pattern_file(path)
    return path


def check_pattern_file(path: Path) -> None:
    """`ValueError` unless `path` is a regular .npz or .csv file of at most MAX_PATTERN_BYTES (an
    .npz's members too, decompressed); says nothing of what the file holds."""
    if path.suffix not in PATTERN_SUFFIXES:
        raise ValueError(f"{path}: a pattern file is .npz or .csv, not {path.suffix or 'a file without suffix'}")
    info = os.stat(path)
    if not stat.S_ISREG(info.st_mode):
        raise ValueError(f"{path}: not a regular file")
    if info.st_size > MAX_PATTERN_BYTES:
        raise ValueError(f"{path}: {info.st_size:,} bytes, a pattern file may have at most {MAX_PATTERN_BYTES:,}")
    if path.suffix == ".npz":
        try:
            with zipfile.ZipFile(path) as archive:
                unpacked = sum(member.file_size for member in archive.infolist())
        except (zipfile.BadZipFile, OSError, ValueError):
            raise ValueError(f"{path}: not an .npz archive") from None
        if unpacked > MAX_PATTERN_BYTES:
            raise ValueError(
                f"{path}: unpacks to {unpacked:,} bytes, a pattern file may have at most {MAX_PATTERN_BYTES:,}"
            )


@functools.lru_cache(maxsize=8)
def load_pattern_file(source: str) -> PatternFile:
    """Load a pattern file: npz with t_s, azimuth_deg, zenith_deg; npz as `write_tables` writes
    (azimuth_rad, elevation_rad float32, shots_per_s, lasers); or Livox CSV `time,azimuth,zenith`."""
    path = resolve(source)
    lasers = None
    try:  # what a malformed file makes numpy say may quote it: never passed on
        if path.suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                if "azimuth_rad" in data.files:
                    az, el = (np.asarray(data[k], np.float64).reshape(-1) for k in ("azimuth_rad", "elevation_rad"))
                    rate, lasers = float(data["shots_per_s"]), int(data["lasers"])
                    t = np.arange(1, len(az) + 1) / rate
                    az, zen = np.degrees(az), 90.0 - np.degrees(el)
                else:
                    t, az, zen = (
                        np.asarray(data[k], np.float64).reshape(-1) for k in ("t_s", "azimuth_deg", "zenith_deg")
                    )
        else:
            t, az, zen = _read_csv(path)
    except (ValueError, KeyError, TypeError, OSError, EOFError, zipfile.BadZipFile, UnicodeDecodeError):
        raise ValueError(
            f"{path}: not a pattern file (.npz with t_s, azimuth_deg, zenith_deg, or CSV rows time,azimuth,zenith)"
        ) from None
    if not len(t) == len(az) == len(zen) or not (
        np.isfinite(t).all() and np.isfinite(az).all() and np.isfinite(zen).all()
    ):
        raise ValueError(f"{path}: t_s, azimuth_deg and zenith_deg must be finite columns of one length")
    if len(t) < 2 or np.any(np.diff(t) <= 0):
        raise ValueError(f"{path}: needs at least 2 shots in increasing time order")
    if lasers is not None and not 1 <= lasers <= min(255, len(t)):
        raise ValueError(f"{path}: lasers must be in 1..255 and at most the shots, got {lasers}")
    return PatternFile(path.name, t, dirs_from_livox(az, zen), lasers)


def file_shots(source: str) -> Shots:
    """The file's own shots as `Shots` (head frame), window (t_first - dt, t_last], `line` row mod
    the file's lasers: the reference."""
    pattern = load_pattern_file(source)
    line = np.arange(len(pattern.t_s)) % (pattern.lasers or 1)
    return make_shots(pattern.t_s, pattern.dirs, pattern.t_s[0] - pattern.dt_s, pattern.t_s[-1], line=line)


def _read_csv(path: Path) -> tuple[NDArray, NDArray, NDArray]:
    """Columns of a Livox CSV (a header line, then `time,azimuth,zenith` rows; extra columns ignored)."""
    with open(path, encoding="utf-8") as f:
        first = f.readline(4096)
    try:
        [float(v) for v in first.split(",")[:3]]
        skip = 0
    except ValueError:
        skip = 1
    data = np.loadtxt(path, delimiter=",", skiprows=skip, usecols=(0, 1, 2), ndmin=2)
    return data[:, 0], data[:, 1], data[:, 2]


def directions(
    source: str, t_s: NDArray[np.float64], line: NDArray | None = None, lasers: int = 1
) -> NDArray[np.float32]:
    """(N, 3) float32 head-frame directions of the file replayed at times `t_s`, shot i by laser
    line[i] of `lasers` (default all laser 0 of 1), looping with a warning."""
    pattern = load_pattern_file(source)
    if pattern.lasers not in (None, lasers):
        raise ValueError(
            f"replay of {pattern.name}: the file interleaves {pattern.lasers} lasers, the head has {lasers}"
        )
    rounds = len(pattern.t_s) // lasers  # rows of each laser in one loop
    n = rounds * lasers
    u = (np.asarray(t_s, np.float64) - pattern.t_s[0]) / pattern.dt_s  # position in the file, in shots
    if len(u) and (u.min() < -_EPS or u.max() > n - 1 + _EPS):
        warnings.warn(
            f"replay of {pattern.name} loops past the file's end ({n * pattern.dt_s:g} s) at pattern "
            f"times ({t_s[0]:g}, {t_s[-1]:g}] s: the pattern repeats and jumps at the seam",
            PatternLoopWarning,
            stacklevel=4,
        )
    laser = np.zeros(len(u), np.intp) if line is None else np.asarray(line, np.intp)
    u = (u - laser) / lasers  # position along the laser's own rows laser + lasers j
    whole = np.floor(u + _EPS / lasers)  # a file shot's own time gives exactly that shot
    frac = np.maximum(u - whole, 0.0).astype(np.float32)
    whole -= rounds * np.floor(whole / rounds)
    i = whole.astype(np.intp) * lasers + laser
    out = np.empty((len(i), 3), np.float32)
    if not frac.any():  # on the file's own clock: its shots, as they are
        for axis, column in enumerate(pattern.columns32):
            out[:, axis] = np.take(column, i)
        return out
    j = i + lasers
    j[j >= n] -= n
    for axis, column in enumerate(pattern.columns32):
        a = np.take(column, i)
        out[:, axis] = a + (np.take(column, j) - a) * frac
    out /= np.linalg.norm(out, axis=1, keepdims=True)  # chords between shots, the seam's too, back to unit
    return out
