"""The scan: the scenario's sensors placed on the pitch (`sensor_rig`), turning scan-pattern shots into
`Rays` (`rays`), and what a dataset records of each sensor (`sensor_info`)."""
