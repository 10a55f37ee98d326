"""Livox's own point cloud message, `CustomMsg` of `CustomPoint`s, as its two ROS drivers define it.

livox_ros_driver2 (ROS 2; Mid-360, HAP) publishes `livox_ros_driver2/msg/CustomMsg`; livox_ros_driver (ROS 1;
Mid-40, Mid-70, Mid-100, Avia, Horizon, Tele-15) publishes `livox_ros_driver/msg/CustomMsg`, which reaches
ROS 2 bags under that name (as `rosbags-convert` writes a ROS 1 bag's). Both have the same fields (the drivers'
msg/CustomMsg.msg and msg/CustomPoint.msg):

- `CustomMsg`: `header` (std_msgs/Header; its stamp = `timebase`), `timebase` uint64 (ns, the first point's
  time), `point_num` uint32, `lidar_id` uint8 (the driver's handle of the lidar unit), `rsvd` uint8[3]
  (reserved, 0), `points` CustomPoint[].
- `CustomPoint`: `offset_time` uint32 (ns since `timebase`), `x y z` float32 (m), `reflectivity` uint8
  (0-255), `tag` uint8 (Livox's point flags), `line` uint8 (the laser of the unit that fired).
"""

from __future__ import annotations

import functools

CUSTOM_POINT_FIELDS = """uint32 offset_time
float32 x
float32 y
float32 z
uint8 reflectivity
uint8 tag
uint8 line
"""

#: The drivers' ROS packages: the message types are `<package>/msg/CustomMsg` and `<package>/msg/CustomPoint`.
DRIVER2, DRIVER1 = "livox_ros_driver2", "livox_ros_driver"


def custom_msg_type(package: str) -> str:
    return f"{package}/msg/CustomMsg"


def custom_msg_fields(package: str) -> str:
    return f"""std_msgs/Header header
uint64 timebase
uint32 point_num
uint8 lidar_id
uint8[3] rsvd
{package}/CustomPoint[] points
"""


@functools.cache
def typestore():
    """rosbags' ROS 2 Humble typestore, with both drivers' `CustomMsg` and `CustomPoint` added."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    for package in (DRIVER2, DRIVER1):
        store.register(get_types_from_msg(CUSTOM_POINT_FIELDS, f"{package}/msg/CustomPoint"))
        store.register(get_types_from_msg(custom_msg_fields(package), custom_msg_type(package)))
    return store
