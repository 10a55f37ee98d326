"""The PointPillars tracklet detector: pillar features, backbone, temporal fusion, SSD head."""
