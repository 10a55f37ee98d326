"""The KITTI virtual camera: labels as KITTI tools read them, 2D boxes tall enough to be kept."""

from __future__ import annotations

import numpy as np
import pytest

from simgen.datasets import kitti_camera as camera
from simgen.datasets.formats.kitti import UNKNOWN_OCCLUSION, label_lines, parse_labels
from tests.support.datasets import make_clip, sensors


def _boxes(rng: np.random.Generator, n: int, height_m: float) -> np.ndarray:
    xy = np.column_stack([rng.uniform(-camera.MAX_X_M, camera.MAX_X_M, n), rng.uniform(-40, 40, n)])
    sizes = np.column_stack([rng.uniform(0.2, 1.2, n), rng.uniform(0.2, 1.0, n), np.full(n, height_m)])
    return np.column_stack([xy, sizes[:, 2] / 2, sizes, rng.uniform(-np.pi, np.pi, n)]).astype(np.float32)


def test_calib_matches_the_conversion_kitti_tools_apply():
    calib = {line.split(":")[0]: np.array(line.split(":")[1].split(), float) for line in camera.calib_lines(False)}
    velo_to_cam = calib["Tr_velo_to_cam"].reshape(3, 4)
    p2 = calib["P2"].reshape(3, 4)
    rng = np.random.default_rng(0)
    points = rng.uniform(-50, 50, (100, 3)).astype(np.float32).astype(np.float64)  # exact for float32 inputs
    cam = points @ velo_to_cam[:, :3].T + velo_to_cam[:, 3]
    np.testing.assert_array_equal(cam, camera.to_camera(points))
    np.testing.assert_array_equal(camera.from_camera(cam), points)
    # A box's 2D box is its corners projected with P2, as OpenPCDet's and mmdet3d's KITTI tools do.
    box = _boxes(rng, 1, 1.8).astype(np.float64)
    corners = camera.to_camera(camera.corners(box)[0])
    uvw = np.column_stack([corners, np.ones(8)]) @ p2.T
    uv = uvw[:, :2] / uvw[:, 2:]
    np.testing.assert_allclose(camera.image_boxes(box)[0], [*uv.min(0), *uv.max(0)])
    tracking = camera.calib_lines(True)
    assert [line.split()[0] for line in tracking] == [
        "P0:",
        "P1:",
        "P2:",
        "P3:",
        "R_rect",
        "Tr_velo_cam",
        "Tr_imu_velo",
    ]


def test_2d_boxes_of_humanoids_are_tall_enough_for_kitti_evaluators():
    boxes = _boxes(np.random.default_rng(1), 2000, camera.MIN_BOX_HEIGHT_M)
    bbox = camera.image_boxes(boxes.astype(np.float64))
    assert (bbox[:, 3] - bbox[:, 1]).min() >= camera.MIN_BOX_PX


def test_the_nominal_image_holds_the_pitch_and_its_players():
    x, y, z = np.meshgrid([-camera.MAX_X_M, camera.MAX_X_M], [-camera.MAX_Y_M, camera.MAX_Y_M], camera.Z_RANGE_M)
    cam = camera.to_camera(np.column_stack([x.ravel(), y.ravel(), z.ravel()]))
    u = camera.FOCAL_PX * cam[:, 0] / cam[:, 2] + camera.PRINCIPAL_PX[0]
    v = camera.FOCAL_PX * cam[:, 1] / cam[:, 2] + camera.PRINCIPAL_PX[1]
    assert u.min() >= 0 and u.max() <= camera.IMAGE_SIZE_PX[0]
    assert v.min() >= 0 and v.max() <= camera.IMAGE_SIZE_PX[1]


def _float32_bev_area(boxes: np.ndarray, distance_m: float) -> np.ndarray:
    """Shoelace area of each box's BEV rectangle in camera (x, z) coordinates, in float32 as GPU IoU kernels do."""
    xy = camera.corners(boxes)[:, [0, 2, 6, 4], :2]  # bottom corners, in order around the box
    x_cam, z_cam = (-xy[..., 1]).astype(np.float32), (xy[..., 0] + distance_m).astype(np.float32)
    after_x, after_z = np.roll(x_cam, -1, axis=1), np.roll(z_cam, -1, axis=1)
    return np.abs(np.sum(x_cam * after_z - after_x * z_cam, axis=1, dtype=np.float32)) / np.float32(2)


def test_camera_coordinates_keep_float32_areas_exact_enough():
    """A footprint computed in float32 camera coordinates, as OpenPCDet's IoU kernels do: with the camera near
    the pitch the median error is under 0.02 % (at worst 1 % for a 0.2 m box); 1000 m away, over 0.1 %."""
    rng = np.random.default_rng(2)
    boxes = _boxes(rng, 500, 1.8).astype(np.float64)
    exact = boxes[:, 3] * boxes[:, 4]
    near = np.abs(_float32_bev_area(boxes, camera.CAMERA_DISTANCE_M) - exact) / exact
    far = np.abs(_float32_bev_area(boxes, 1000.0) - exact) / exact
    assert np.median(near) < 2e-4 and near.max() < 1e-2
    assert np.median(far) > 1e-3
    assert camera.to_camera(camera.corners(boxes).reshape(-1, 3))[:, 2].min() >= camera.NEAR_DEPTH_M - 1.0


@pytest.mark.parametrize("yaw", [0.0, np.pi / 2, -np.pi / 2, np.pi, -3.0, 3.0])
def test_rotation_y_is_the_kitti_convention(yaw):
    box = np.array([[10.0, -5.0, 0.9, 1.0, 0.5, 1.8, yaw]], np.float32)
    fields = camera.kitti_boxes(box)
    expected = -float(box[0, 6]) - np.pi / 2
    assert np.cos(fields["ry"][0]) == pytest.approx(np.cos(expected)) and np.sin(fields["ry"][0]) == pytest.approx(
        np.sin(expected)
    )
    assert -np.pi < fields["ry"][0] <= np.pi
    np.testing.assert_array_equal(fields["location"][0], [5.0, 0.0, 10.0 + camera.CAMERA_DISTANCE_M])  # bottom centre
    np.testing.assert_array_equal(fields["dims"][0], np.array([1.8, 0.5, 1.0], np.float32))


def test_label_lines_have_kitti_fields_and_mark_boxes_without_points():
    frame = make_clip("clip_0000", 1, seed=3)[0]
    lines = label_lines(frame)
    rows = [line.split() for line in lines]
    assert all(len(row) == 15 for row in rows)
    occluded = np.array([int(row[2]) for row in rows])
    np.testing.assert_array_equal(occluded == UNKNOWN_OCCLUSION, frame.labels.num_points == 0)
    assert (frame.labels.num_points == 0).any()
    parsed = parse_labels("\n".join(lines), "label.txt", tracking=False)
    np.testing.assert_array_equal(parsed["boxes"][:, :6], frame.labels.boxes[:, :6])


def test_placeholder_images_have_the_virtual_cameras_size_and_are_listed(tmp_path):
    from PIL import Image

    from simgen.datasets import finish_dataset, open_dataset, write_clip
    from simgen.qa.integrity import verify_dataset
    from simgen.qa.tolerances import load_tolerances

    clips = [make_clip("clip_0000", 2, seed=0), make_clip("clip_0001", 3, seed=1)]
    records = [write_clip(tmp_path, "kitti", frames, sensors(), i) for i, frames in enumerate(clips)]
    manifest = finish_dataset(
        tmp_path, "kitti", records, sensors(), {"name": "f", "dataset": {"kitti_images": True}}, 0
    )
    images = sorted((tmp_path / "training" / "image_2").glob("*.png"))
    velodyne = sorted((tmp_path / "training" / "velodyne").glob("*.bin"))
    assert [p.stem for p in images] == [p.stem for p in velodyne] == ["000000", "000001", "010000", "010001", "010002"]
    for path in images:
        with Image.open(path) as image:
            assert image.size == camera.IMAGE_SIZE_PX  # what OpenPCDet's get_image_shape reads (as rows, columns)
    assert {f"training/image_2/{p.name}" for p in images} <= {f.path for f in manifest.files}
    assert "`training/image_2/NNNNNN.png`: blank placeholders" in (tmp_path / "README.md").read_text()
    assert verify_dataset(tmp_path, load_tolerances().labels).problems == ()
    assert len(open_dataset(tmp_path)) == 5


def test_placeholder_images_are_for_kitti_only():
    from simgen.errors import UserError
    from simgen.scenario import parse_scenario

    assert parse_scenario({"name": "x", "dataset": {"format": "kitti", "kitti_images": True}}).dataset.kitti_images
    with pytest.raises(UserError, match="placeholder images are for format kitti, not openpcdet"):
        parse_scenario({"name": "x", "dataset": {"format": "openpcdet", "kitti_images": True}})


def test_the_openpcdet_card_gives_a_class_map_and_a_dataset_yaml_that_fit_the_data(tmp_path):
    import re

    import yaml

    from simgen.datasets import openpcdet_config
    from tests.support.datasets import write_dataset

    write_dataset(tmp_path, "openpcdet", [make_clip("clip_0000", 3)])
    card = (tmp_path / "README.md").read_text()
    config = yaml.safe_load(re.search(r"```yaml\n(.*?)```", card, re.S).group(1))
    assert config == openpcdet_config.custom_dataset_config()
    names = {line.split()[-1] for path in (tmp_path / "labels").glob("*.txt") for line in path.read_text().splitlines()}
    # no KeyError in evaluation
    assert names == {"Pedestrian", "Official"} and names <= set(config["MAP_CLASS_TO_KITTI"])
    kitti_names = {"Car", "Van", "Truck", "Pedestrian", "Person_sitting", "Cyclist", "Tram", "Misc", "DontCare"}
    for officials in openpcdet_config.OFFICIAL_AS:
        mapping = openpcdet_config.class_map(officials)
        assert set(mapping.values()) <= kitti_names and set(openpcdet_config.class_names(officials)) <= set(mapping)
        assert f"`MAP_CLASS_TO_KITTI: {mapping}`" in card
    low, high = np.array(config["POINT_CLOUD_RANGE"][:3]), np.array(config["POINT_CLOUD_RANGE"][3:])
    assert np.all(low[:2] < -np.array([52.5, 34.0])) and np.all(high[:2] > [52.5, 34.0])  # the whole pitch
    voxel = np.array(config["DATA_PROCESSOR"][-1]["VOXEL_SIZE"])
    grid = (high - low) / voxel
    np.testing.assert_allclose(grid, np.round(grid), atol=1e-6)
    assert np.all(np.round(grid[:2]) % 16 == 0) and round(grid[2]) == 1  # PointPillars: one pillar, strides divide
