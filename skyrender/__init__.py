"""skyrender: camera pose from one mountain photograph and a DEM."""

__version__ = "0.1.0"
