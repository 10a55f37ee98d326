"""simgen: simulated sparse, stationary Livox LiDAR watching football.

Pipeline (one way): scenario -> motion -> scene -> scan -> labels -> writer.
See ARCHITECTURE.md for the map of modules.
"""

__version__ = "0.1.0"
