"""Per-head identity outside the bags: OpenPCDet's points carry each point's lidar unit as a fifth column
(a source feature its model does not use), which reads back as the Parquet dataset's sensor and head; KITTI's
`.bin` has room for four values only and keeps none."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

import simgen.datasets
from simgen.datasets import openpcdet_config
from simgen.datasets.formats import openpcdet
from simgen.datasets.units import lidar_units, unit_numbers, unit_sensor_head
from simgen.errors import UserError
from tests.support.datasets import make_clip, mid40, sensors, with_mid40

SENSORS = [*sensors(), mid40()]  # a Mid-100 (units 0-2) and a Mid-40 (unit 3)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    from simgen.datasets import finish_dataset, write_clip

    root = tmp_path_factory.mktemp("units")
    for fmt in ("parquet", "openpcdet"):
        record = write_clip(root / fmt, fmt, with_mid40(make_clip("clip_0000", 3, points=200), 4), SENSORS, 0)
        finish_dataset(root / fmt, fmt, [record], SENSORS, {"name": "units"}, 3)
    return root


def test_units_are_numbered_across_sensors_in_sensor_then_head_order():
    assert [(u.sensor.name, u.head, u.lidar_id) for u in lidar_units(SENSORS)] == [
        ("mid100", 0, 0), ("mid100", 1, 1), ("mid100", 2, 2), ("mid40", 0, 3)]
    sensor, head = np.array([1, 0, 0, 0], np.uint8), np.array([0, 2, 0, 1], np.uint8)
    numbers = unit_numbers(sensor, head, SENSORS)
    np.testing.assert_array_equal(numbers, [3, 2, 0, 1])
    np.testing.assert_array_equal(np.stack(unit_sensor_head(numbers, SENSORS)), [sensor, head])
    with pytest.raises(ValueError, match="0 to 3"):
        unit_sensor_head(np.array([4.0]), SENSORS)


def test_openpcdet_points_carry_the_unit_that_fired_each(written):
    parquet, pcdet = simgen.datasets.open(written / "parquet"), simgen.datasets.open(written / "openpcdet")
    assert pcdet.plugin.carries.units and not pcdet.plugin.carries.point_fields
    for want, got in zip(parquet, pcdet):
        np.testing.assert_array_equal(got.sensor, want.sensor)
        np.testing.assert_array_equal(got.head, want.head)
        raw = np.load(written / "openpcdet" / openpcdet.points_path(0, want.index))
        assert raw.dtype == np.float32 and raw.shape == (len(want.points_m), len(openpcdet.COLUMNS))
        np.testing.assert_array_equal(raw[:, 4], unit_numbers(want.sensor, want.head, SENSORS))
    # OpenPCDet reads the unit as a source feature and leaves it out of the model's input
    card = (written / "openpcdet" / "README.md").read_text()
    config = yaml.safe_load(card.split("```yaml\n")[1].split("```")[0])
    encoding = config["POINT_FEATURE_ENCODING"]
    assert encoding["src_feature_list"] == list(openpcdet.COLUMNS)
    assert encoding["used_feature_list"] == ["x", "y", "z", "intensity"]
    assert config == openpcdet_config.custom_dataset_config()


def test_openpcdet_points_of_four_columns_read_and_other_shapes_are_one_line_errors(tmp_path):
    four = np.ones((3, 4), np.float32)
    assert openpcdet.read_points(openpcdet.npy_bytes(four), tmp_path / "a.npy", 3).shape == (3, 4)
    with pytest.raises(UserError, match=r"a.npy: float32 \(3, 6\), expected float32 \(3, 5\)"):
        openpcdet.read_points(openpcdet.npy_bytes(np.ones((3, 6), np.float32)), tmp_path / "a.npy", 3)
