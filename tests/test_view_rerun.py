"""`simgen view --rerun`: the recording loads back through Rerun's own dataframe API, entity by entity."""

from __future__ import annotations

import numpy as np
import pytest
import rerun as rr
from dataset_factory import make_clip, sensors, write_dataset

import simgen.datasets
from simgen.cli import main

FRAMES = range(1, 6)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
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
        table = dataset.reader(index="frame").select(*columns).to_arrow_table()
        entities = sorted({c.entity_path for c in schema.component_columns()})
    return simgen.datasets.open(root / "dataset"), entities, table.sort_by("frame").to_pydict()


def test_the_recording_has_the_pitch_sensors_frusta_points_and_boxes(recording):
    _, entities, _ = recording
    sensor = sensors()[0].name
    assert entities == sorted(["/world", "/world/pitch", f"/world/sensors/{sensor}", f"/world/sensors/{sensor}/frustum",
                               "/world/points", "/world/boxes", "/world/headings"])


def test_every_frame_is_on_the_game_time_timeline_with_its_points_and_boxes(recording):
    data, _, rows = recording
    assert rows["frame"] == list(FRAMES)
    for row, index in enumerate(FRAMES):
        frame = data.frame("clip_0000", index)
        assert rows["game_time"][row].total_seconds() == pytest.approx(frame.time_s, abs=1e-6)
        np.testing.assert_array_equal(np.array(rows["/world/points:Points3D:positions"][row], np.float32), frame.points_m)
        assert len(set(rows["/world/points:Points3D:colors"][row])) > 10  # coloured by intensity, not one colour
        np.testing.assert_array_equal(np.array(rows["/world/boxes:Boxes3D:centers"][row], np.float32), frame.boxes[:, :3])
        assert rows["/world/boxes:Boxes3D:labels"][row] == [str(t) for t in frame.track_id]
        headings = np.array(rows["/world/headings:Arrows3D:vectors"][row])
        np.testing.assert_allclose(np.arctan2(headings[:, 1], headings[:, 0]), frame.boxes[:, 6], atol=1e-6)


def test_bad_rerun_arguments_are_one_line(tmp_path, capsys):
    write_dataset(tmp_path / "d", "parquet", [make_clip("clip_0000", 2)])
    assert main(["view", str(tmp_path / "d")]) == 2
    assert capsys.readouterr().err == "simgen view: error: nothing to write: give -o OUT (pictures, exports) or --rerun FILE.rrd\n"
    assert main(["view", str(tmp_path / "d"), "--rerun", str(tmp_path / "clip.mp4")]) == 2
    assert "expected a file name ending in .rrd" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.rrd")) and not list(tmp_path.glob(".*"))
