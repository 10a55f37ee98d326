"""`simgen pattern`: write a preset's shots in the layout of Livox's official pattern files."""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

from simgen import __version__
from simgen.atomic import atomic_path
from simgen.commands.arguments import LazyText, add_command
from simgen.errors import UserError
from simgen.output_path import check_output

MAX_SHOTS = 50_000_000  # ~1.3 GB of output; ask for longer spans in pieces with --start


def _presets_help() -> str:
    from scan_patterns import get_sensor, sensor_names

    rows = []
    for name in sensor_names():
        sensor = get_sensor(name)
        rows.append(f"  {name:<15} {sensor.shots_per_s:>9,.0f} shots/s  {sensor.description}")
    return "\n".join(rows)


def register(subparsers) -> None:
    parser = add_command(
        subparsers,
        "pattern",
        "write a scan pattern's shots (time, azimuth, zenith, head) to .npz",
        "Write the shots that a sensor preset fires in the window (START, START + SECONDS], "
        "in the layout of Livox's official pattern files: t_s [s], azimuth_deg, zenith_deg "
        "(90 = boresight) as float64 and head (uint8). Directions are in the sensor's frame "
        "(x forward, y left, z up; azimuth positive towards y), each head's yaw and pitch "
        "applied; heads follow one another, each in time order. A replayed file that runs "
        "out is looped, with a warning.",
    )
    parser.epilog = LazyText(lambda: "presets:\n" + _presets_help())
    parser.add_argument("preset", metavar="PRESET", help="sensor preset (listed below)")
    parser.add_argument("--seconds", type=float, required=True, help="length of the window, s")
    parser.add_argument(
        "--density", type=float, default=1.0, help="shots per second factor, any positive number (default 1)"
    )
    parser.add_argument("--start", type=float, default=0.0, help="start of the window, s (default 0)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output .npz file")
    parser.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    import scan_patterns as sp

    if not math.isfinite(args.seconds) or args.seconds <= 0:
        raise UserError(f"--seconds must be a positive number, got {args.seconds:g}")
    if not math.isfinite(args.density) or args.density <= 0:
        raise UserError(f"--density must be a positive number, got {args.density:g}")
    if not math.isfinite(args.start) or args.start < 0:
        raise UserError(f"--start must be zero or positive, got {args.start:g}")
    check_output(args.output, "file")
    try:
        sensor = sp.get_sensor(args.preset)
    except ValueError as error:
        raise UserError(str(error)) from None
    expected = sensor.shots_per_s * args.density * args.seconds
    if expected > MAX_SHOTS:
        raise UserError(
            f"{expected:,.0f} shots is more than {MAX_SHOTS:,}: ask for a shorter --seconds, in pieces with --start"
        )
    t0, t1 = args.start, args.start + args.seconds
    with atomic_path(args.output) as tmp:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", sp.PatternLoopWarning)
            try:
                shots = sp.shots(sensor, t0, t1, args.density)
            except ValueError as error:  # e.g. a replay file that is missing
                raise UserError(str(error)) from None
        for message in dict.fromkeys(str(w.message) for w in caught):
            print(f"simgen pattern: warning: {message}", file=sys.stderr)
        azimuth_deg, zenith_deg = sp.livox_angles(shots.dirs)
        note = (
            f"simgen {__version__} pattern {args.preset}: window ({t0:g}, {t1:g}] s, density x{args.density:g}, "
            f"{sensor.shots_per_s * args.density:,.0f} shots/s; sensor frame x forward, y left, z up; "
            "azimuth_deg about z from x towards y, zenith_deg 90 = boresight (Livox's layout); head = head index; line "
            "= the head's laser"
        )
        try:
            with open(tmp, "wb") as f:
                np.savez(
                    f,
                    t_s=shots.t_s,
                    azimuth_deg=azimuth_deg,
                    zenith_deg=zenith_deg,
                    head=shots.head,
                    line=shots.line,
                    note=note,
                )
        except OSError as error:
            raise UserError(f"{args.output}: cannot write ({error.strerror})") from None
    print(f"{args.output}: {len(shots):,} shots of {args.preset} in ({t0:g}, {t1:g}] s")
    return 0
