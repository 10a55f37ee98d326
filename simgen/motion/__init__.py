"""Motion: the football engine plays and its skeletons are recorded (`engine`), as a `MotionClip`
(`clip`), kept on disk as Parquet (`clip_io`), read at any time between captured frames
(`interpolate`). Keypoints from joint angles, for tests and benchmarks, are in tests/support/poses.py."""
