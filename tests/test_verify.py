"""`simgen verify`: checksums, schema version, unlisted files and label sanity, each problem at FILE:ROW."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from simgen.cli import main
from simgen.datasets import FORMATS
from simgen.datasets.frame import Frame
from simgen.datasets.schema import SCHEMA_VERSION
from simgen.labels.boxes import FrameLabels
from simgen.labels.labelled_frame import LabelledFrame
from simgen.qa.label_checks import box_problems, count_problems, track_problems
from simgen.qa.tolerances import load_tolerances
from simgen.render.frame import ScanFrame
from simgen.vocab import GROUND, PLAYER
from tests.support.datasets import sample_clips, write_dataset
from tests.support.processes import run_simgen

TOL = load_tolerances().labels
BOX = [10.0, 5.0, 0.9, 0.6, 0.5, 1.8, 0.3]  # x, y, z, length, width, height, yaw


def clean_clip(clip: str = "clip_0000", frames: int = 3) -> list[LabelledFrame]:
    """Two humanoids walking at 1 m/s along x, their points inside their boxes, ground points round them."""
    rng = np.random.default_rng(1)
    out = []
    for index in range(frames):
        centres = np.array([[10.0 + 0.1 * index, 5.0, 0.9], [-20.0 + 0.1 * index, -8.0, 0.9]])
        body = np.concatenate([c + rng.uniform(-0.2, 0.2, (12, 3)) for c in centres])
        ground = np.column_stack([rng.uniform(-50, 50, 200), rng.uniform(-30, 30, 200), np.zeros(200)])
        points = np.concatenate([body, ground]).astype(np.float32)
        instance = np.concatenate([np.full(12, 1), np.full(12, 2), np.full(200, -1)]).astype(np.int32)
        n = len(points)
        scan = ScanFrame(points, rng.integers(0, 150, n).astype(np.uint8), np.linspace(0, 0.1, n).astype(np.float32),
                         np.zeros(n, np.uint8), np.zeros(n, np.uint8), instance,
                         np.where(instance > 0, PLAYER, GROUND).astype(np.uint8), n + 50, 0, 50)
        boxes = np.array([[*c[:2], 0.9, 0.6, 0.5, 1.8, 0.0] for c in centres], np.float32)
        labels = FrameLabels(boxes, np.array([1, 2], np.int32), np.array(["left", "right"]), np.array(["CM", "CB"]),
                             np.tile(np.float32([1.0, 0.0, 0.0]), (2, 1)), np.zeros((2, 12, 3), np.float32),
                             np.array([12, 12], np.int32), np.zeros(2, bool))
        out.append(LabelledFrame(clip, index, 1.0 + index / 10, 1.05 + index / 10, scan, labels))
    return out


def verify(path, *extra):
    """The command in a subprocess, as a user runs it."""
    result = run_simgen("verify", path, *extra)
    return result.returncode, result.stdout.splitlines(), result.stderr


@pytest.fixture
def verify_here(capsys):
    """The command in this process (no start-up cost): exit code and stdout lines."""
    def run(path):
        code = main(["verify", str(path)])
        return code, capsys.readouterr().out.splitlines(), ""
    return run


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_clean_dataset_verifies_and_a_flipped_byte_names_its_file(tmp_path, fmt, verify_here):
    verify = verify_here
    write_dataset(tmp_path, fmt, [clean_clip("clip_0000"), clean_clip("clip_0001")])
    code, lines, _ = verify(tmp_path)
    assert code == 0 and lines[-1].startswith(f"{tmp_path}: ok (")
    listed = json.loads((tmp_path / "manifest.json").read_text())["files"]
    victim = tmp_path / next(f["path"] for f in listed if "0001" in f["path"] and f["bytes"] > 100)
    data = bytearray(victim.read_bytes())
    data[len(data) // 2] ^= 0x01
    victim.write_bytes(bytes(data))
    code, lines, _ = verify(tmp_path)
    assert code == 1
    assert f"{victim}: sha256 differs from manifest.json (corrupt or modified)" in lines
    assert lines[-1].startswith(f"{tmp_path}: 1 problem (")


def test_schema_version_unlisted_files_and_bad_input(tmp_path):
    write_dataset(tmp_path, "parquet", [clean_clip()])
    stray = tmp_path / "points" / "clip_0000" / "part-1.parquet"
    stray.write_bytes(b"not listed")
    code, lines, _ = verify(tmp_path)
    assert code == 1 and f"{stray}: not listed in manifest.json (readers that glob the folders would read it)" in lines
    manifest = tmp_path / "manifest.json"
    manifest.write_text(manifest.read_text().replace(f'"schema_version": {SCHEMA_VERSION}', '"schema_version": 99'))
    code, lines, _ = verify(tmp_path)
    assert code == 1 and lines[0] == f"{manifest}: schema version 99, this simgen reads {SCHEMA_VERSION}"
    code, lines, stderr = verify(tmp_path / "missing")
    assert code == 2 and stderr == f"simgen verify: error: {tmp_path / 'missing'}: no such dataset directory\n"


def test_label_problems_are_reported_at_their_file_and_line(tmp_path, verify_here):
    """The factory's boxes jump about the pitch from frame to frame: each jump names its label line."""
    write_dataset(tmp_path, "kitti_tracking", sample_clips()[:1])
    code, lines, _ = verify_here(tmp_path)
    assert code == 1
    labels = tmp_path / "training" / "label_02" / "0000.txt"
    rows = labels.read_text().splitlines()
    jumps = [line for line in lines if line.startswith(f"{labels}:") and " moved at " in line]
    assert jumps
    for line in jumps:
        number = int(line.split(":")[1])
        track = int(line.split("track id ")[1].split()[0])
        assert int(rows[number - 1].split()[1]) == track  # the line holds that track's box


def _frame(boxes, track_id, index=0, points=None, instance=None, num_points=None, velocity=None, placed=None) -> Frame:
    boxes = np.asarray(boxes, np.float32).reshape(-1, 7)
    points = np.zeros((0, 3), np.float32) if points is None else np.asarray(points, np.float32)
    return Frame(
        "c",
        index,
        points,
        np.zeros(len(points), np.uint8),
        boxes,
        np.array(["Pedestrian"] * len(boxes)),
        track_id=np.asarray(track_id, np.int32),
        instance_id=None if instance is None else np.asarray(instance, np.int32),
        num_points=None if num_points is None else np.asarray(num_points, np.int32),
        velocity_mps=np.zeros((len(boxes), 3), np.float32) if velocity is None else np.asarray(velocity, np.float32),
        discontinuity=None if placed is None else np.asarray(placed, bool),
    )


def locate(frame, box):
    return "labels.txt", 10 * frame + box + 1


def test_boxes_off_the_pitch_of_odd_size_or_under_the_ground():
    boxes = [BOX, [60.0, 0, 0.9, 0.6, 0.5, 1.8, 0], [0, 0, 0.9, 0.6, 3.5, 1.8, 0], [0, 0, 0.5, 0.6, 0.5, 1.8, 0],
             [0, 0, 0.9, 0.6, 0.5, 1.8, 4.0], [0, 0, np.nan, 0.6, 0.5, 1.8, 0]]
    found = [str(p) for p in box_problems(_frame(boxes, range(6)), locate, TOL)]
    assert found == [
        "labels.txt:2: box centre (60.00, 0.00) m is off the pitch grown by 5 m",
        "labels.txt:3: box width 3.500 m outside 0.05-3 m",
        "labels.txt:4: box bottom at z = -0.400 m, under the ground",
        "labels.txt:5: yaw 4.000 rad outside [-pi, pi]",
        "labels.txt:6: box has a value that is not finite",
    ]


def test_stored_counts_against_instance_ids_and_the_box():
    inside, outside = [10.0, 5.0, 1.0], [12.0, 5.0, 1.0]
    frame = _frame([BOX, BOX], [1, 2], points=[inside, inside, outside], instance=[1, 1, 2], num_points=[2, 2])
    found = [str(p) for p in count_problems(frame, locate, 0.05, TOL)]
    assert found == ["labels.txt:2: num_points is 2, the frame has 1 point of track id 2"]
    frame = _frame([BOX], [1], points=[inside, outside], instance=[1, 1], num_points=[2])
    assert [str(p) for p in count_problems(frame, locate, 0.05, TOL)] == [
        "labels.txt:1: 1 point inside the box (grown by 0.30 m), num_points is 2"]
    fast = _frame([BOX], [1], points=[inside, outside], instance=[1, 1], num_points=[2], velocity=[[40.0, 0, 0]])
    assert count_problems(fast, locate, 0.05, TOL) == []  # 40 m/s x 0.05 s: its box reaches the point
    placed = _frame([BOX], [1], points=[inside, outside], instance=[1, 1], num_points=[2], placed=[True])
    assert count_problems(placed, locate, 0.05, TOL) == []  # placed mid-sweep: its points lie at both places


def test_a_point_after_the_label_time_may_lie_in_the_next_frames_box():
    """A stride: at 0.09 s into the frame the foot is 0.8 m ahead of the box of 0.05 s, inside the box of the
    next frame (0.15 s). Accepted there, not when the point is earlier than the label time (then only the
    previous frame's box counts), and not in a placed neighbour's box."""
    foot = [10.8, 5.0, 0.3]
    longer = [10.4, 5.0, 0.9, 1.0, 0.5, 1.8, 0.0]

    def frame(offset_s: float, index: int = 1, **extra) -> Frame:
        return replace(
            _frame([BOX[:6] + [0.0]], [1], index=index, points=[foot], instance=[1], num_points=[1], **extra),
            time_s=1.0,
            label_time_s=1.05,
            time_offset_s=np.float32([offset_s]),
        )

    after, before = _frame([longer], [1], index=2), _frame([BOX[:6] + [0.0]], [1], index=0)
    assert count_problems(frame(0.09), locate, 0.05, TOL, before, after) == []
    assert [str(p) for p in count_problems(frame(0.01), locate, 0.05, TOL, before, after)] == [
        "labels.txt:11: 0 points inside the box (grown by 0.30 m), num_points is 1"]
    placed_after = replace(after, discontinuity=np.array([True]))
    assert len(count_problems(frame(0.09), locate, 0.05, TOL, before, placed_after)) == 1


def test_track_ids_twice_missing_or_jumping():
    at = np.array([BOX, BOX], np.float32)
    moved = at.copy()
    moved[1, 0] += 2.0  # 2 m in 0.1 s: 20 m/s
    tracks = [
        (0, np.array([1, 2]), at, None),
        (1, np.array([1, 2]), moved, None),
        (2, np.array([2, 2]), moved[[1, 1]], None),
        (4, np.array([1]), at[:1], None),
    ]
    found = [str(p) for p in track_problems(tracks, locate, 10.0, TOL)]
    assert found == [
        "labels.txt:12: track id 2 moved at 20.0 m/s since frame 0 (limit 12)",
        "labels.txt:22: track id 2 appears 2 times in frame 2",
        "labels.txt:41: track id 1 is missing from frames 2-3",
    ]


def test_a_jump_is_a_problem_unless_the_engine_placed_the_humanoid():
    """Speeds are checked within a segment: a flagged jump starts a new one, the same jump unflagged is a teleport."""
    at = np.array([BOX, BOX], np.float32)
    far = at.copy()
    far[:, 0] += 30.0  # both 30 m away a frame later
    tracks = [(0, np.array([1, 2]), at, None), (1, np.array([1, 2]), far, np.array([True, False])),
              (2, np.array([1, 2]), far, np.array([False, False]))]
    assert [str(p) for p in track_problems(tracks, locate, 10.0, TOL)] == [
        "labels.txt:12: track id 2 moved at 300.0 m/s since frame 0 (limit 12)"]


def _placed_30_m_back(frame: LabelledFrame, flagged: bool) -> LabelledFrame:
    """Humanoid 1 (box 0) and its points 30 m further back along x; its flag as given."""
    shift = np.float32([-30.0, 0.0, 0.0])
    scan, labels = frame.scan, frame.labels
    points = scan.points_m + shift * (scan.instance_id == 1)[:, None]
    boxes = labels.boxes.copy()
    boxes[0, :3] += shift
    return replace(frame, scan=replace(scan, points_m=points.astype(np.float32)),
                   labels=replace(labels, boxes=boxes, discontinuity=np.array([flagged, False])))


def test_verify_tells_a_placement_from_a_teleport(tmp_path, verify_here):
    """The same 30 m jump in a written dataset: with its discontinuity flag it verifies, without it it is
    reported at the box's row, in every format that carries track ids."""
    for fmt in ("parquet", "kitti_tracking", "mcap"):
        for flagged in (True, False):
            frames = clean_clip("clip_0000", frames=6)
            frames[3:] = [_placed_30_m_back(f, flagged and f.index == 3) for f in frames[3:]]
            root = tmp_path / f"{fmt}_{flagged}"
            write_dataset(root, fmt, [frames])
            code, lines, _ = verify_here(root)
            jumps = [line for line in lines if "moved at" in line]
            if flagged:
                assert code == 0 and not jumps, (fmt, lines)
            else:
                assert code == 1 and len(jumps) == 1 and "track id 1 moved at" in jumps[0], (fmt, lines)
