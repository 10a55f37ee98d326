"""Bodies: articulated humanoid meshes posed from the 12 keypoints (`mesh`) and which way a body faces (`heading`)."""
