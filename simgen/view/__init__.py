"""Pictures of a dataset: bird's-eye and side views of frames (`render`), PNGs and an MP4 of a
clip (`output`), and frames exported as PCD or PLY for CloudCompare or Open3D (`export`).

The choices below are here, light to import, for the command line."""

COLOURINGS = ("height", "intensity")  # what colours the points
EXPORT_FORMATS = ("pcd", "ply")  # point-cloud files Open3D writes
