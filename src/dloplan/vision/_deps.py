"""Lazy imports of the optional ``vision`` extra (OpenCV, scikit-image).

``import dloplan.vision`` never imports them; a function that needs one calls :func:`cv2` or
:func:`skimage_morphology`, which raise an ImportError naming the extra to install.
"""

from __future__ import annotations

import importlib

_HINT = "pip install dloplan[vision]"


def _require(module: str, package: str):
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(
            f"{module} ({package}) is needed for this function and is not installed: "
            f"run `{_HINT}`"
        ) from exc


def cv2():
    """The ``cv2`` module (opencv-python-headless)."""
    return _require("cv2", "opencv-python-headless")


def skimage_morphology():
    """``skimage.morphology`` (scikit-image)."""
    return _require("skimage.morphology", "scikit-image")
