"""Livox's official scan tables: what each one holds (`scan_patterns.write_tables` turns them into our files).

Livox publishes, per sensor, a table of shot directions (Livox-SDK/livox_laser_simulation,
`scan_mode/*.csv`, MIT: mid40, mid70, avia, horizon, tele since 2021, HAP and mid360 since 2023).
The PyPI package `mujoco-lidar` 0.3.5 (MIT) carries float32 copies, `mujoco_lidar/scan_mode/*.npy`:
N x 2, radians, column 0 the azimuth, column 1 the elevation with a sign that differs between the
copies (`elevation_sign`), no time column. The facts below were measured on those copies
(docs/scan_patterns.md, scan_patterns/reference/README.md):

- row i is laser i mod `lasers` (each laser's own rows draw a smooth curve, its neighbours' do not),
  fired at (i + 1) / `shots_per_s` seconds, evenly spaced, as Livox's drivers time their points;
- each table is 4 s long, except HAP's: 1,048,575 rows, Excel's row cap, 2.32 s of its stream.

    pip download mujoco-lidar==0.3.5 --no-deps -d /tmp/ml && unzip /tmp/ml/*.whl -d /tmp/ml
    python -m scan_patterns.write_tables /tmp/ml/mujoco_lidar/scan_mode -o ~/livox --full
    SIMGEN_LIVOX_DIR=~/livox simgen qa --pattern avia-replay -o /tmp/qa    # the whole 4 s tables

Without `--full` it writes the excerpts shipped in scan_patterns/reference/ (`excerpt_s` each).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LivoxTable:
    """One official table and the layout of its float32 copy in mujoco-lidar 0.3.5."""

    name: str  # the official name: `replay` file and scan_patterns/reference/<name>_official_*.npz
    source: str  # file name in mujoco_lidar/scan_mode/
    source_sha256: str
    rows: int
    lasers: int  # row i is laser (line) i mod lasers
    shots_per_s: float  # all lasers together
    elevation_sign: int  # elevation = elevation_sign x column 1 of the copy
    excerpt_s: float  # seconds of the table shipped in scan_patterns/reference/

    @property
    def seconds(self) -> float:
        return self.rows / self.shots_per_s

    def excerpt_rows(self, seconds: float) -> int:
        """Rows of the first `seconds`, whole rounds of the lasers (HAP's last 3 rows make no round)."""
        return min(round(seconds * self.shots_per_s), self.rows) // self.lasers * self.lasers

    def file_name(self, full: bool) -> str:
        seconds = self.excerpt_rows(self.seconds if full else self.excerpt_s) / self.shots_per_s
        return f"{self.name}_official_{seconds:.3g}s.npz"


# Mid-40 and Mid-70 ship as they always did (float64 degrees with times, `replay.OFFICIAL_FILES`).
# Elevation signs: Mid-360's checked against a CSV copy of Livox's file (first row 268.99, zenith
# 37.838 -> elevation +52.162, the copy's column 1); Mid-40's and Mid-70's against CSV copies too
# (column 1 = zenith - 90 = -elevation). Avia, Horizon, Tele-15 and HAP have symmetric vertical
# fields of view and no CSV copy could be reached: taken as the other tables of their copy, -1.
TABLES = {
    table.name: table
    for table in (
        LivoxTable("avia", "avia.npy", "2054fc915ad5e141d366b62d039eaa3ae936c437f65f5d1b926046d06b239f31",
                   960_000, 6, 240_000.0, -1, 0.5),
        LivoxTable("horizon", "horizon.npy", "bf7706c899b0c253e75054c799f2cf94161e9d1c9e8fed9aad0f46f20d839399",
                   960_000, 6, 240_000.0, -1, 0.5),
        LivoxTable("tele", "tele.npy", "3a5d0240fdafd95d7ebe34caee421dcbd9cb5c86f72b3ea87f59ea1065b8bd35",
                   960_000, 6, 240_000.0, -1, 0.5),
        LivoxTable("hap", "HAP.npy", "0a1552624f3f377aa6daeff0e69797d00cd6089a4cc646a16f19868048623825",
                   1_048_575, 6, 452_000.0, -1, 0.5),
        LivoxTable("mid360", "mid360.npy", "9fa0165576f0060488254f04bd647a891004d4f4faa6e9b03b69d830c117c9a3",
                   800_000, 4, 200_000.0, 1, 4.0),
    )
}
