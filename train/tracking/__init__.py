"""Data association: the paper's 3D DIoU tracker, the AB3DMOT baseline and the pieces they share."""
