"""Scores: KITTI AP of the detector (detection, ap_table, decomposition, learning_curve) and the
trackers' metrics (tracking: AB3DMOT's sAMOTA and CLEAR MOT; hota; kitti export)."""
