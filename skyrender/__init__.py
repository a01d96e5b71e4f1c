"""skyrender: camera pose from one mountain photograph and a DEM."""

__version__ = "0.1.0"


def localize(image, model, height, fov=None, prior=None, **kwargs):
    """Camera pose from one photograph: see :func:`skyrender.localizer.localize`."""
    from .localizer import localize as _localize

    return _localize(image, model, height, fov, prior, **kwargs)
