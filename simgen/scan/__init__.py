"""The scan: the scenario's sensors placed on the pitch (`sensor_rig`), turning scan-pattern shots into
`Rays` (`rays`), and `Sensor` (`sensor`), the one description of a sensor from the scan to the datasets and QA."""
