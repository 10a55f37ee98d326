"""Lidar units: the heads of a dataset's sensors (a Mid-100 has three), numbered across its sensors.

A unit's number (its `lidar_id` in Livox's CustomMsg, the `lidar_unit` column of OpenPCDet's points) counts the
units of all sensors in sensor id order, then head order: as a Livox driver numbers the lidars it connects (its
handles) when its config lists them in that order.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from simgen.errors import UserError

if TYPE_CHECKING:
    from simgen.scan.sensor import Sensor

MAX_UNITS = 256  # a uint8 numbers them, as CustomMsg's lidar_id


@dataclass(frozen=True)
class LidarUnit:
    """A head of a sensor and its number across the dataset's sensors (`lidar_id`)."""

    sensor: Sensor
    head: int
    lidar_id: int


def lidar_units(sensors: Sequence[Sensor]) -> list[LidarUnit]:
    """Every unit of `sensors`, numbered."""
    ordered = sorted(sensors, key=lambda s: s.sensor_id)
    units = [(sensor, head) for sensor in ordered for head in range(len(sensor.heads))]
    if len(units) > MAX_UNITS:
        raise UserError(f"{len(units)} lidar units: a uint8 (Livox's lidar_id) numbers at most {MAX_UNITS}")
    return [LidarUnit(sensor, head, number) for number, (sensor, head) in enumerate(units)]


def unit_numbers(sensor: NDArray[np.uint8], head: NDArray[np.uint8], sensors: Sequence[Sensor]) -> NDArray[np.uint8]:
    """(P,) the unit number of each point, from its (P,) sensor id and head."""
    first = np.zeros(max(s.sensor_id for s in sensors) + 1, np.int64)
    for unit in lidar_units(sensors):
        if unit.head == 0:
            first[unit.sensor.sensor_id] = unit.lidar_id
    return (first[np.asarray(sensor)] + np.asarray(head)).astype(np.uint8)


def unit_sensor_head(numbers: NDArray, sensors: Sequence[Sensor]) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Inverse of `unit_numbers`: (P,) sensor ids and heads; ValueError for a number no unit has."""
    units = lidar_units(sensors)
    numbers = np.asarray(numbers)
    if len(numbers) and (numbers.min() < 0 or numbers.max() >= len(units) or np.any(numbers != np.rint(numbers))):
        raise ValueError(f"lidar unit numbers must be whole, 0 to {len(units) - 1}")
    index = numbers.astype(np.int64)
    sensor = np.array([u.sensor.sensor_id for u in units], np.uint8)[index]
    return sensor, np.array([u.head for u in units], np.uint8)[index]
