"""`simgen view --rerun`: the recording loads back through Rerun's own dataframe API, entity by entity,
with its boxes at the times the ROS 2 bag gives its markers."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
import rerun as rr
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

import simgen.datasets
from simgen.cli import main
from simgen.datasets.formats.mcap import BOXES_TOPIC
from tests.support.datasets import make_clip, sensors, write_dataset

FRAMES = range(1, 6)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """(dataset, entities, rows by frame with the latest game time, rows by game time (ns)) of a recording of FRAMES."""
    root = tmp_path_factory.mktemp("rerun")
    write_dataset(root / "dataset", "parquet", [make_clip("clip_0000", 6)])
    path = root / "clip.rrd"
    assert main(["view", str(root / "dataset"), "--rerun", str(path), "--frames", f"{FRAMES.start}:{FRAMES.stop}",
                 "--colour", "intensity"]) == 0
    with rr.server.Server(host="127.0.0.1", datasets={"clip": [str(path)]}) as server:
        dataset = server.client().get_dataset("clip")
        schema = dataset.schema()
        columns = ["frame", "game_time", "/world/points:Points3D:positions", "/world/points:Points3D:colors",
                   "/world/boxes:Boxes3D:centers", "/world/boxes:Boxes3D:labels", "/world/headings:Arrows3D:vectors"]
        by_frame = dataset.reader(index="frame").select(*columns).to_arrow_table().sort_by("frame")
        by_time = dataset.reader(index="game_time").select(*columns).to_arrow_table().sort_by("game_time")
        entities = sorted({c.entity_path for c in schema.component_columns()})
    by_time = by_time.set_column(
        by_time.schema.get_field_index("game_time"), "game_time", by_time["game_time"].cast(pa.int64())
    )
    return simgen.datasets.open(root / "dataset"), entities, by_frame.to_pydict(), by_time.to_pydict()


def test_the_recording_has_the_pitch_sensors_frusta_points_and_boxes(recording):
    _, entities, _, _ = recording
    sensor = sensors()[0].name
    assert entities == sorted(["/world", "/world/pitch", f"/world/sensors/{sensor}", f"/world/sensors/{sensor}/frustum",
                               "/world/points", "/world/boxes", "/world/headings"])


def test_every_frame_has_its_points_and_boxes(recording):
    data, _, rows, _ = recording
    assert rows["frame"] == list(FRAMES)
    for row, index in enumerate(FRAMES):
        frame = data.frame("clip_0000", index)
        np.testing.assert_array_equal(
            np.array(rows["/world/points:Points3D:positions"][row], np.float32), frame.points_m
        )
        assert len(set(rows["/world/points:Points3D:colors"][row])) > 10  # coloured by intensity, not one colour
        np.testing.assert_array_equal(
            np.array(rows["/world/boxes:Boxes3D:centers"][row], np.float32), frame.boxes[:, :3]
        )
        assert rows["/world/boxes:Boxes3D:labels"][row] == [str(t) for t in frame.track_id]
        headings = np.array(rows["/world/headings:Arrows3D:vectors"][row])
        np.testing.assert_allclose(np.arctan2(headings[:, 1], headings[:, 0]), frame.boxes[:, 6], atol=1e-6)


def _logged_at(rows: dict, column: str) -> list[int]:
    """Game times (ns) at which `column` was logged."""
    return [t for t, value in zip(rows["game_time"], rows[column]) if value is not None]


def test_points_are_at_the_sweep_start_and_boxes_at_the_label_time_as_in_the_bag(recording, tmp_path):
    data, _, _, rows = recording
    frames = [data.frame("clip_0000", index) for index in FRAMES]
    assert _logged_at(rows, "/world/points:Points3D:positions") == [round(f.time_s * 1e9) for f in frames]
    boxes = _logged_at(rows, "/world/boxes:Boxes3D:centers")
    assert (
        boxes == _logged_at(rows, "/world/headings:Arrows3D:vectors") == [round(f.label_time_s * 1e9) for f in frames]
    )
    bag = tmp_path / "clip"
    assert main(["export", str(data.root), "-o", str(bag), "--frames", f"{FRAMES.start}:{FRAMES.stop}"]) == 0
    with (bag / "clip.mcap").open("rb") as stream:
        markers = [m.markers[0].header.stamp for _, c, _, m in make_reader(stream, decoder_factories=[DecoderFactory()])
                   .iter_decoded_messages(topics=[BOXES_TOPIC])]
    assert boxes == [stamp.sec * 1_000_000_000 + stamp.nanosec for stamp in markers]


def test_bad_rerun_arguments_are_one_line(tmp_path, capsys):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 2)])
    assert main(["view", str(tmp_path / "d")]) == 2
    assert (
        capsys.readouterr().err
        == "simgen view: error: nothing to write: give -o OUT (pictures, exports) or --rerun FILE.rrd\n"
    )
    assert main(["view", str(tmp_path / "d"), "--rerun", str(tmp_path / "clip.mp4")]) == 2
    assert "expected a file name ending in .rrd" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.rrd")) and not list(tmp_path.glob(".*"))
