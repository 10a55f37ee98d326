"""Labels: oriented boxes, track ids and points per box from the keypoints (`boxes`), and the
`LabelledFrame` the writers receive (`labelled_frame`)."""
