"""The `mcap` format: a ROS 2 bag per clip, the directory `<clip id>/` with `<clip id>.mcap` and rosbag2's
`metadata.yaml` (`simgen.datasets.ros2_bag`, whose mcap and rosbags imports wait until a bag is written or read)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from simgen.datasets import ros2_bag
from simgen.datasets.formats.base import Carries, DatasetFormat, Locate
from simgen.datasets.manifest import ClipEntry, Manifest
from simgen.datasets.records import FileRecord
from simgen.datasets.samples import MAX_FRAMES_PER_CLIP


class Mcap(DatasetFormat):
    name = "mcap"
    carries = Carries(track_ids=True, point_fields=True, point_counts=False)
    max_frames_per_clip = MAX_FRAMES_PER_CLIP  # the limit every format but parquet had; the reader decodes a clip whole

    def stream(self, root, clip, clip_index, sensors):
        return ros2_bag.McapClipStream(root, clip, sensors)

    def reader(self, files, manifest):
        return ros2_bag.BagReader(files, manifest)

    def clip_files(self, entry: ClipEntry) -> set[str]:
        return {ros2_bag.bag_path(entry.clip), ros2_bag.bag_metadata_path(entry.clip)}

    def listed_rows_problem(self, entry: ClipEntry, listed: Mapping[str, FileRecord], sensors: int) -> str | None:
        rows = listed[ros2_bag.bag_path(entry.clip)].rows
        if rows == ros2_bag.bag_messages(entry.frames, sensors):
            return None
        return f"clip {entry.clip} lists {entry.frames} frames, its bag {rows} messages"

    def card_layout(self, manifest: Manifest) -> list[str]:
        return ros2_bag.card_lines()

    def locator(self, root: Path, entry: ClipEntry, first_row: dict[int, int]) -> Locate:
        bag = str(root / ros2_bag.bag_path(entry.clip))
        return lambda k, i: (bag, first_row[k] + i)  # box of the clip, from 0, in the /simgen/boxes messages


FORMAT = Mcap()
