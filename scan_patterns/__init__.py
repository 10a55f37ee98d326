"""scan_patterns: Livox non-repetitive scan patterns (shot times and directions per head) and
the metrics that say how faithful a pattern is.

    import scan_patterns as sp
    sensor = sp.get_sensor("mid100-risley")
    frame = sp.frame_shots(sensor, 0, frame_rate_hz=10, density=2, sweeps_per_frame=2)
    frame.t_s, frame.dirs, frame.head, frame.sweep  # seconds, sensor-frame unit vectors, indices

Conventions (head frame x forward, y left, z up; Livox azimuth/zenith) are in `shots`;
docs/scan_patterns.md has the presets, the Risley fit and how to add a head.
"""

from scan_patterns.metrics import (
    BEAM_DIVERGENCE_DEG,
    CELL_SIZES_DEG,
    COVERAGE_TIMES_S,
    FieldOfView,
    PatternComparison,
    RadialProfile,
    compare,
    coverage_curve,
    field_coords,
    radial_density,
    target_points_per_frame,
)
from scan_patterns.replay import PatternLoopWarning, file_shots, load_pattern_file
from scan_patterns.risley import MID40, RisleyParams
from scan_patterns.rose import RoseParams
from scan_patterns.sensors import (
    OFFICIAL_HEADS,
    HeadSpec,
    SensorSpec,
    UnknownSensorError,
    find_sensor,
    get_sensor,
    make_head,
    make_sensor,
    official_table,
    register_sensor,
    sensor_names,
)
from scan_patterns.shots import Shots, livox_angles
from scan_patterns.stream import frame_shots, frame_window, head_shots, shots, sweep_index

__all__ = [
    "BEAM_DIVERGENCE_DEG",
    "CELL_SIZES_DEG",
    "COVERAGE_TIMES_S",
    "MID40",
    "OFFICIAL_HEADS",
    "FieldOfView",
    "HeadSpec",
    "PatternComparison",
    "PatternLoopWarning",
    "RadialProfile",
    "RisleyParams",
    "RoseParams",
    "SensorSpec",
    "Shots",
    "UnknownSensorError",
    "compare",
    "coverage_curve",
    "field_coords",
    "file_shots",
    "find_sensor",
    "frame_shots",
    "frame_window",
    "get_sensor",
    "head_shots",
    "livox_angles",
    "load_pattern_file",
    "make_head",
    "make_sensor",
    "official_table",
    "radial_density",
    "register_sensor",
    "sensor_names",
    "shots",
    "sweep_index",
    "target_points_per_frame",
]
