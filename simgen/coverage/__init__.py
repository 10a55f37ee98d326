"""Coverage of sensor rigs over the pitch, measured by rendering (`simgen coverage`)."""
