"""The answer of ``POST /v1/segmentation``: the object instances of a depth image."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Tuple

import numpy as np

from .common import Camera, ImageInfo, floats, optional_float


@dataclass(frozen=True)
class Instance:
    """One object.

    ``id`` is 1..N, best score first, and the count of its pixels in the label image.
    ``score`` is the segmenter's confidence in [0, 1] (with the shipped model, >= 0.25 is
    confident). ``bbox_px`` is (x, y, width, height) and ``centroid_px`` (u, v) in pixels;
    ``centroid_m`` (x, y, z) the mean of its points in the camera frame, metres;
    ``top_height_m`` its highest surface above the floor. ``mean_deformability`` (0 rigid ... 1
    very soft) is None with the PCL baseline; ``mean_stiffness`` (0 soft ... 1 hard) None
    without a stiffness model."""

    id: int
    score: float
    area_px: int
    bbox_px: Tuple[int, ...]
    centroid_px: Tuple[float, ...]
    centroid_m: Tuple[float, ...]
    top_height_m: float
    mean_deformability: Optional[float]
    mean_stiffness: Optional[float]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Instance":
        return cls(int(d["id"]), float(d["score"]), int(d["area_px"]),
                   tuple(int(v) for v in d["bbox_px"]), floats(d["centroid_px"]),
                   floats(d["centroid_m"]), float(d["top_height_m"]),
                   optional_float(d["mean_deformability"]), optional_float(d["mean_stiffness"]))


@dataclass(frozen=True)
class Segmentation:
    """The instances and, when asked for, the label image.

    ``labels`` is a uint16 array of the depth's height x width: each pixel holds the id of its
    instance, 0 = background (None when ``Client.segmentation(labels=False)``). Pass it back as
    ``Client.grasps(labels=...)`` to grasp by these ids. ``method`` is the segmenter that ran
    (model, pcl, fused); ``timing_ms`` the server's stage times; ``raw`` the JSON answer."""

    method: str
    instances: List[Instance]
    labels: Optional[np.ndarray] = field(repr=False, compare=False)
    image: ImageInfo
    camera: Camera
    segmentation_model: Optional[str]
    stiffness_model: Optional[str]
    timing_ms: Dict[str, float]
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Dict[str, Any], labels: Optional[np.ndarray]) -> "Segmentation":
        return cls(str(d["method"]), [Instance.from_json(i) for i in d["instances"]], labels,
                   ImageInfo.from_json(d["image"]), Camera.from_json(d["camera"]),
                   d.get("segmentation_model"), d.get("stiffness_model"),
                   {k: float(v) for k, v in d["timing_ms"].items()}, d)
