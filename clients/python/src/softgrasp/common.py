"""Values several answers share: the camera, the decoded image, a pose.

Conventions of the service: metres and radians unless a name ends in ``_mm`` or ``_px``; the
camera frame is OpenCV's (x right, y down, z forward along the optical axis); pixels are (u, v) =
(column, row); quaternions are (w, x, y, z).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Optional, Tuple


def floats(values: Any) -> Tuple[float, ...]:
    return tuple(float(v) for v in values)


def optional_float(value: Any) -> Optional[float]:
    return None if value is None else float(value)


@dataclass(frozen=True)
class Camera:
    """Pinhole intrinsics, pixels: focal lengths fx, fy and principal point cx, cy of a
    width x height image. ``source`` is "request" or "default" in answers (which camera was
    used); it is not sent when a Camera is passed as intrinsics."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    source: Optional[str] = None

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Camera":
        return cls(float(d["fx"]), float(d["fy"]), float(d["cx"]), float(d["cy"]),
                   int(d["width"]), int(d["height"]), d.get("source"))


@dataclass(frozen=True)
class ImageInfo:
    """The depth image as the server decoded it: size in pixels, file format (npy, png16,
    tiff) and the fraction of pixels without a reading (0 or NaN)."""

    width: int
    height: int
    format: str
    missing_fraction: float

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "ImageInfo":
        return cls(int(d["width"]), int(d["height"]), str(d["format"]),
                   float(d["missing_fraction"]))


@dataclass(frozen=True)
class Pose:
    """A pose in ``frame`` ("camera" for image grasps, "table" for mesh poses): position
    (x, y, z) in metres and orientation as a unit quaternion (w, x, y, z)."""

    frame: str
    position_m: Tuple[float, ...]
    orientation_wxyz: Tuple[float, ...]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Pose":
        return cls(str(d["frame"]), floats(d["position_m"]), floats(d["orientation_wxyz"]))
