"""City maps: buildings, RotorPy world JSON, generators, rasterisation and 2D LiDAR."""

from windnav.city.core import City

__all__ = ["City"]
