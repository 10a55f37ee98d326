"""Rendering a LiDAR frame: the clip-long `World` (`world`), first hits with Embree (`raycast`) and the
candidate rays per body (`candidates`), the sensor's noise (`noise`), one frame end to end (`frame`)."""
