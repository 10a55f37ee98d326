"""The PointPillars tracklet detector: its parts (pillar features, backbone, temporal fusion, SSD head),
target assignment, loss, post-processing and NMS, streaming inference and tracklet files."""
