"""Write Livox's official tables (mujoco-lidar 0.3.5's float32 copies) as our npz files: the excerpts
shipped in scan_patterns/reference/, or with --full the whole tables for $SIMGEN_LIVOX_DIR.

    python -m scan_patterns.write_tables /tmp/ml/mujoco_lidar/scan_mode -o ~/livox [--full]
"""

from __future__ import annotations

import argparse
import hashlib
import os
from pathlib import Path

import numpy as np

from scan_patterns.livox_tables import TABLES, LivoxTable

NOTE = (
    "Livox's official {name} scan table (Livox-SDK/livox_laser_simulation scan_mode, MIT), rows 0..{last} of "
    "the float32 copy {source} in mujoco-lidar 0.3.5 (MIT, sha256 {sha}); elevation = {sign:+d} x its column 1; "
    "row i is laser i mod {lasers}, fired at (i + 1) / {rate:g} s"
)


def write_table(table: LivoxTable, source_dir: Path, out_dir: Path, full: bool) -> Path:
    """Our npz of `table` (the excerpt, or with `full` the whole table) from mujoco-lidar's copy."""
    path = Path(source_dir) / table.source
    data = path.read_bytes()
    sha = hashlib.sha256(data).hexdigest()
    if sha != table.source_sha256:
        raise ValueError(f"{path}: sha256 {sha}, not mujoco-lidar 0.3.5's {table.source_sha256}")
    angles = np.load(path, allow_pickle=False)
    rows = table.excerpt_rows(table.seconds if full else table.excerpt_s)
    note = NOTE.format(name=table.name, last=rows - 1, source=table.source, sha=sha, sign=table.elevation_sign,
                       lasers=table.lasers, rate=table.shots_per_s)
    out = Path(out_dir) / table.file_name(full)
    tmp = out.with_name(f".{out.name}.tmp-{os.getpid()}")
    with open(tmp, "wb") as f:
        np.savez_compressed(
            f,
            azimuth_rad=np.ascontiguousarray(angles[:rows, 0], np.float32),
            elevation_rad=np.ascontiguousarray(angles[:rows, 1] * np.float32(table.elevation_sign), np.float32),
            shots_per_s=np.float64(table.shots_per_s),
            lasers=np.int64(table.lasers),
            note=np.str_(note),
        )
    os.replace(tmp, out)  # never a half-written file under the final name
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m scan_patterns.write_tables", description=__doc__.split("\n")[0])
    parser.add_argument("source", type=Path, help="mujoco_lidar/scan_mode of the unzipped mujoco-lidar 0.3.5 wheel")
    parser.add_argument("-o", "--output", type=Path, required=True, help="folder to write into (SIMGEN_LIVOX_DIR)")
    parser.add_argument("--full", action="store_true", help="whole tables instead of the shipped excerpts")
    args = parser.parse_args(argv)
    for table in TABLES.values():
        print(write_table(table, args.source, args.output, args.full))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
