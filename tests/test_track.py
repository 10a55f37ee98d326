"""`simgen-train track` end to end on a generated paper_x1-like dataset (2 clips of 16 frames): from a checkpoint,
from KITTI detections, online from an MCAP bag; online equals offline; bad input is one line and exit 2."""

from __future__ import annotations

import csv
import subprocess
import sys

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest
import yaml

import simgen.datasets
from tests.support import ROOT
from tests.support.detector import tiny_config
from tests.support.kitti_detections import write_detections
from train.cli import main
from train.detector.detections import kitti_lines
from train.track.outputs import TRACKS_SCHEMA, TRACKS_TOPIC, TRAIL_FRAMES, ClipBag
from train.tracking.types import TrackedFrame

PAPER_X1 = ROOT / "scenarios" / "paper_x1.yaml"
FRAMES = 16
VAL = "clip_0001"  # the split puts the last of 2 clips in val


def _run(*args: object) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=600)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """(dataset, checkpoint, bag of the val clip): paper_x1 cut to 2 clips of 16 frames, a tiny late model fitted
    for 2 iterations that keeps its 30 best boxes a frame (untrained, nothing else would pass a threshold)."""
    root = tmp_path_factory.mktemp("track")
    scenario = yaml.safe_load(PAPER_X1.read_text())
    scenario.update(name="tiny_paper_x1")
    scenario["motion"].update(frames=250, skip_s=0.0)
    scenario["scan"]["frames"] = FRAMES
    scenario["dataset"]["clips"] = 2
    (root / "tiny.yaml").write_text(yaml.safe_dump(scenario))
    dataset = root / "dataset"
    done = _run("simgen.cli", "generate", root / "tiny.yaml", "-o", dataset)
    assert done.returncode == 0, done.stderr
    config = tiny_config("late").model_dump(mode="json")
    config["infer"].update(score_threshold=0.0, max_detections=30)
    (root / "late.yaml").write_text(yaml.safe_dump(config))
    done = _run("train.cli", "fit", root / "late.yaml", "--dataset", dataset, "-o", root / "run", "--iterations", 2,
                "--quiet")
    assert done.returncode == 0, done.stderr
    bag = root / VAL  # a rosbag2 directory
    done = _run("simgen.cli", "export", dataset, "--clip", VAL, "-o", bag)
    assert done.returncode == 0, done.stderr
    return dataset, root / "run" / "checkpoint.pt", bag


def track(capsys, *args: object) -> tuple[int, str, str]:
    """`simgen-train track ARGS` in this process: exit code, stdout, stderr."""
    code = main(["track", *map(str, args), "--quiet"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def check_outputs(out, clip: str) -> None:
    """KITTI tracking results, the tracks table and an MCAP whose /simgen/tracks has boxes and trajectories."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    lines = [line.split() for line in (out / "kitti" / f"{clip}.txt").read_text().splitlines()]
    assert lines and all(len(f) == 18 and f[2] == "Pedestrian" for f in lines)
    table = pq.read_table(out / "tracks.parquet")
    assert table.schema.names == TRACKS_SCHEMA.names
    table = table.filter(pc.equal(table["clip"], clip))
    assert table.num_rows == len(lines)
    assert set(table.column("state").to_pylist()) <= {"tentative", "confirmed", "dying"}
    assert sorted(zip(table.column("frame").to_pylist(), table.column("track_id").to_pylist())) == sorted(
        (int(f[0]), int(f[1])) for f in lines)
    kinds = set()
    with open(out / "mcap" / clip / f"{clip}.mcap", "rb") as stream:
        for _, _, _, message in make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                topics=[TRACKS_TOPIC]):
            kinds |= {(m.ns, m.type) for m in message.markers if m.action == 0}
    assert {("tracks", 1), ("track_ids", 9), ("trajectories", 4)} <= kinds


@pytest.mark.engine
def test_track_from_a_checkpoint(tiny, tmp_path, capsys):
    dataset, checkpoint, _ = tiny
    code, out, err = track(capsys, "--dataset", dataset, "--checkpoint", checkpoint, "-o", tmp_path, "--min-score", 0)
    assert code == 0, err
    check_outputs(tmp_path, VAL)
    assert "sAMOTA" in out and "HOTA" in out
    rows = list(csv.DictReader(open(tmp_path / "metrics.csv")))
    assert len(rows) == 1 and {"samota", "amota", "amotp", "mota", "motp", "ids", "frag", "hota"} <= set(rows[0])


@pytest.mark.engine
def test_track_from_kitti_detections_of_the_labels(tiny, tmp_path, capsys):
    """Single-frame detections, associated frame to frame: most players tracked, by about one track each."""
    dataset, _, _ = tiny
    labelled = write_detections(dataset, tmp_path / "detections", np.random.default_rng(0))
    code, out, err = track(capsys, "--dataset", dataset, "--detections", tmp_path / "detections", "-o",
                           tmp_path / "out", "--split", "all")
    assert code == 0, err
    for clip in ("clip_0000", VAL):
        check_outputs(tmp_path / "out", clip)
    row = next(csv.DictReader(open(tmp_path / "out" / "metrics.csv")))
    assert float(row["mota"]) > 0.5 and int(row["ids"]) < labelled / 4 and int(row["tracks"]) <= 1.5 * labelled
    assert "MOTA" in out and "per 10 minutes of play IDS" in out
    assert float(row["play_s"]) == pytest.approx(2 * FRAMES / 11, abs=0.01)  # both clips' frames, at 11 Hz


@pytest.mark.engine
def test_a_rerun_recording_holds_points_labels_and_the_tracks(tiny, tmp_path, capsys):
    """Read back through Rerun's own API: each frame's points, labelled boxes and tracks, as the tracks table has
    them."""
    import rerun as rr

    dataset, _, _ = tiny
    write_detections(dataset, tmp_path / "detections", np.random.default_rng(0))
    code, _, err = track(capsys, "--dataset", dataset, "--detections", tmp_path / "detections", "-o", tmp_path / "out",
                         "--rerun", tmp_path / "run.rrd")
    assert code == 0, err
    root = f"/world/{VAL}"
    columns = ["frame", f"{root}/points:Points3D:positions", f"{root}/labels:Boxes3D:labels",
               f"{root}/tracks:Boxes3D:centers", f"{root}/tracks:Boxes3D:labels",
               f"{root}/trajectories:LineStrips3D:strips"]
    with rr.server.Server(host="127.0.0.1", datasets={"run": [str(tmp_path / "run.rrd")]}) as server:
        recorded = server.client().get_dataset("run")
        entities = {c.entity_path for c in recorded.schema().component_columns()}
        rows = recorded.reader(index="frame").select(*columns).to_arrow_table().sort_by("frame").to_pydict()
    assert {"/world/pitch", f"{root}/points", f"{root}/labels", f"{root}/tracks", f"{root}/trajectories"} <= entities
    table = pq.read_table(tmp_path / "out" / "tracks.parquet").to_pandas()
    data = simgen.datasets.open(dataset)
    assert rows["frame"] == list(range(FRAMES))
    for row, index in enumerate(rows["frame"]):
        frame = data.frame(VAL, index)
        np.testing.assert_array_equal(np.array(rows[f"{root}/points:Points3D:positions"][row]), frame.points_m)
        assert rows[f"{root}/labels:Boxes3D:labels"][row] == [str(t) for t in frame.track_id]
        tracks = table[(table["clip"] == VAL) & (table["frame"] == index)]
        assert [label.split()[0] for label in rows[f"{root}/tracks:Boxes3D:labels"][row] or []] == [
            str(t) for t in tracks["track_id"]]
        np.testing.assert_allclose(np.array(rows[f"{root}/tracks:Boxes3D:centers"][row] or np.zeros((0, 3))),
                                   tracks[["x", "y", "z"]].to_numpy(), atol=1e-5)
        assert len(rows[f"{root}/trajectories:LineStrips3D:strips"][row] or []) == len(tracks)


@pytest.mark.engine
def test_online_from_a_bag_at_11_hz(tiny, tmp_path, capsys):
    _, checkpoint, bag = tiny
    code, out, err = track(capsys, "--bag", bag, "--checkpoint", checkpoint, "-o", tmp_path, "--online", "--rate", 11,
                           "--min-score", 0)
    assert code == 0, err
    check_outputs(tmp_path, bag.name)
    rows = list(csv.DictReader(open(tmp_path / "latency.csv")))
    assert rows and set(rows[0]) == {"clip", "frame", "read_ms", "pillars_ms", "network_ms", "decode_ms", "track_ms",
                                     "total_ms"}
    assert all(float(r["total_ms"]) > 0 for r in rows)
    assert "p50 / p99 / max" in out and "late" in out and "dropped" in out and "sAMOTA" in out


@pytest.mark.engine
def test_online_and_offline_give_the_same_tracks(tiny, tmp_path, capsys):
    dataset, checkpoint, _ = tiny
    for mode in ("offline", "online"):
        extra = ["--online"] if mode == "online" else []
        code, _, err = track(capsys, "--dataset", dataset, "--checkpoint", checkpoint, "-o", tmp_path / mode,
                             "--min-score", 0, *extra)
        assert code == 0, err
    offline, online = (pq.read_table(tmp_path / m / "tracks.parquet") for m in ("offline", "online"))
    assert offline.num_rows > 0 and offline.equals(online)
    assert (tmp_path / "offline" / "kitti" / f"{VAL}.txt").read_text() == (
        tmp_path / "online" / "kitti" / f"{VAL}.txt").read_text()


def _bad_detections(folder, dataset_path, change: str) -> None:
    """Detections of the val clip's first frame, one of them spoiled by `change`."""
    dataset = simgen.datasets.open(dataset_path)
    frame = dataset.frame(VAL, 0)
    lines = kitti_lines(frame.boxes, np.full(len(frame.boxes), 0.9, np.float32))
    fields = lines[0].split()
    spoiled = {
        "missing": fields[:-1],
        "extra": [*fields, "1.0"],
        "nan": [*fields[:11], "nan", *fields[12:]],
        "inf": [*fields[:11], "inf", *fields[12:]],
        "zero": [*fields[:8], "0.0", *fields[9:]],
        "negative": [*fields[:9], "-0.5", *fields[10:]],
    }
    clip, name = VAL, "000000.txt"
    if change == "beyond":
        name = f"{FRAMES:06d}.txt"
    elif change == "clip":
        clip = "clip_0099"
    else:
        lines[0] = " ".join(spoiled[change])
    (folder / clip).mkdir(parents=True)
    (folder / clip / name).write_text("".join(f"{line}\n" for line in lines))


@pytest.mark.engine
@pytest.mark.parametrize("change, message", [
    ("missing", "15 columns, expected 16"),
    ("extra", "17 columns, expected 16"),
    ("nan", "NaN or infinite"),
    ("inf", "NaN or infinite"),
    ("zero", "zero or negative size"),
    ("negative", "zero or negative size"),
    ("beyond", f"beyond the clip's {FRAMES} frames"),
    ("clip", "clip 'clip_0099' is not in"),
])
def test_bad_detections_are_one_line_and_write_nothing(tiny, tmp_path, capsys, change, message):
    dataset, _, _ = tiny
    _bad_detections(tmp_path / "detections", dataset, change)
    code, _, err = track(capsys, "--dataset", dataset, "--detections", tmp_path / "detections", "-o",
                         tmp_path / "out")
    assert code == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.engine
def test_bad_sources_are_one_line_and_write_nothing(tiny, tmp_path, capsys):
    dataset, checkpoint, bag = tiny
    (tmp_path / "detections").mkdir()
    code, _, err = track(capsys, "--dataset", dataset, "--checkpoint", checkpoint, "--detections",
                         tmp_path / "detections", "-o", tmp_path / "out")
    assert code == 2 and err.count("\n") == 1 and "exactly one source" in err
    no_points = tmp_path / "boxes_only.mcap"
    from mcap.writer import Writer

    with open(no_points, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        writer.finish()
    code, _, err = track(capsys, "--bag", no_points, "--checkpoint", checkpoint, "-o", tmp_path / "out")
    assert code == 2 and err.count("\n") == 1 and "no points" in err
    code, _, err = track(capsys, "--bag", bag, "--ros2-layout", "livox", "--checkpoint", checkpoint, "-o",
                         tmp_path / "out")
    assert code == 2 and err.count("\n") == 1 and "not in the livox point layout" in err
    code, _, err = track(capsys, "--dataset", dataset, "--checkpoint", checkpoint, "-o", tmp_path / "out", "--rerun",
                         tmp_path / "run.txt")
    assert code == 2 and err.count("\n") == 1 and "ending in .rrd" in err
    code, _, err = track(capsys, "--bag", bag, "--checkpoint", checkpoint, "-o", tmp_path / "out", "--resume")
    assert code == 2 and err.count("\n") == 1 and "--resume" in err
    assert not (tmp_path / "out").exists() and not list(tmp_path.glob("*.rrd")) and not list(tmp_path.glob("run*"))


@pytest.mark.engine
def test_fig6_draws_labelled_beside_tracked_trajectories(tiny, tmp_path, capsys):
    import cv2

    from simgen.cli import main as simgen

    dataset, _, _ = tiny
    write_detections(dataset, tmp_path / "detections", np.random.default_rng(1))
    code, _, err = track(capsys, "--dataset", dataset, "--detections", tmp_path / "detections", "-o", tmp_path / "out")
    assert code == 0, err
    code = simgen(["view", str(dataset), "--clip", VAL, "--tracks", str(tmp_path / "out"), "-o", str(tmp_path / "v")])
    out = capsys.readouterr().out
    assert code == 0 and "ID switch" in out
    picture = cv2.imread(str(tmp_path / "v" / f"{VAL}_tracks.png"))
    assert picture.shape[1] > 2 * picture.shape[0]  # two pitches side by side
    assert (tmp_path / "v" / f"{VAL}_tracks.mp4").read_bytes()[4:8] == b"ftyp"


def test_an_id_switch_is_where_a_labelled_player_changes_track():
    from simgen.view.trajectories import Paths, id_switches

    def paths(ids, xs):
        return Paths([np.array([i]) for i in ids], [np.array([[x, 0.0]]) for x in xs], [np.zeros(1, bool)] * len(ids))

    labels = paths([1, 1, 1, 1], [0.0, 0.5, 1.0, 1.5])
    assert id_switches(labels, paths([5, 5, 7, 7], [0.1, 0.6, 1.1, 1.6])) == [(2, 1.0, 0.0)]
    assert id_switches(labels, paths([5, 5, 7, 7], [0.1, 0.6, 9.0, 1.6])) == [(3, 1.5, 0.0)]  # too far: no match


@pytest.mark.engine
def test_a_bag_keeps_the_trails_of_recent_tracks_only(tiny, tmp_path):
    """A whole match makes thousands of tracks: the bag draws each one's last TRAIL_FRAMES centres, and forgets the
    trails of tracks not shown for TRAIL_FRAMES frames (memory flat in the match's length)."""
    dataset = simgen.datasets.open(tiny[0])
    frame = dataset.frame(VAL, 0)
    bag = ClipBag(tmp_path / "bag", list(dataset.manifest.sensors), simgen.datasets.formats.mcap.SIMGEN_LAYOUT)
    box = np.array([[1.0, 2.0, 0.9, 0.6, 0.6, 1.8, 0.0]])
    for k in range(3 * TRAIL_FRAMES + 10):  # track 0 every frame, track 1000 + k only in frame k
        bag.add(frame, TrackedFrame(np.repeat(box, 2, axis=0), np.array([0, 1000 + k]), np.ones(2)))
    bag.finish()
    assert len(bag.trails[0]) == TRAIL_FRAMES
    assert 1000 + TRAIL_FRAMES not in bag.trails and 1000 + 3 * TRAIL_FRAMES + 9 in bag.trails
    assert len(bag.trails) <= 2 * TRAIL_FRAMES + 1
