"""What a request can carry, turned into multipart parts and form fields."""
from __future__ import annotations

import io
import json
import os
from typing import Dict, List, Mapping, Union

import numpy as np

from ._http import Part
from ._png import encode_grey
from .common import Camera

#: A depth image: an array (float32/float64 in metres, or uint16 in millimetres; shape (H, W) or
#: (H, W, 1)), a file's path (NPY, 16-bit PNG, float TIFF) or its bytes.
Depth = Union[np.ndarray, str, "os.PathLike[str]", bytes]
#: Camera intrinsics: a Camera (its fx, fy, cx, cy in pixels), a dict in any JSON layout the
#: server reads (GQ-CNN .intr, ROS CameraInfo, Open3D, librealsense), a JSON file's path or bytes.
Intrinsics = Union[Camera, Mapping[str, object], str, "os.PathLike[str]", bytes]
#: A mask or label image: an (H, W) array, or a PNG file's path or bytes.
Image = Union[np.ndarray, str, "os.PathLike[str]", bytes]


def _file(name: str, value: Union[str, "os.PathLike[str]", bytes], default_filename: str) -> Part:
    if isinstance(value, (bytes, bytearray, memoryview)):
        return Part(name, bytes(value), default_filename)
    with open(value, "rb") as f:
        return Part(name, f.read(), os.path.basename(os.fspath(value)))


def npy_bytes(array: np.ndarray) -> bytes:
    """The array as an .npy file (numpy.save, no pickles)."""
    buffer = io.BytesIO()
    np.save(buffer, np.ascontiguousarray(array), allow_pickle=False)
    return buffer.getvalue()


def depth_part(depth: Depth) -> Part:
    if isinstance(depth, np.ndarray):
        return Part("depth", npy_bytes(depth), "depth.npy", "application/x-npy")
    return _file("depth", depth, "depth")


def intrinsics_parts(intrinsics: Union[Intrinsics, None]) -> tuple:
    """(form fields, parts) for the camera: a Camera as fx/fy/cx/cy fields, anything else as the
    ``intrinsics`` part."""
    if intrinsics is None:
        return {}, []
    if isinstance(intrinsics, Camera):
        c = intrinsics
        return {"fx": str(c.fx), "fy": str(c.fy), "cx": str(c.cx), "cy": str(c.cy)}, []
    if isinstance(intrinsics, Mapping):
        return {}, [Part("intrinsics", json.dumps(dict(intrinsics)).encode(), "camera.json",
                         "application/json")]
    return {}, [_file("intrinsics", intrinsics, "camera.json")]


def segmask_part(segmask: Image) -> Part:
    """GQ-CNN's segmask: non-zero = contacts allowed; an array becomes an 8-bit PNG (0 or 255)."""
    if isinstance(segmask, np.ndarray):
        mask = np.squeeze(segmask) if segmask.ndim == 3 else segmask
        return Part("segmask", encode_grey(np.where(mask != 0, 255, 0).astype(np.uint8)),
                    "segmask.png", "image/png")
    return _file("segmask", segmask, "segmask.png")


def labels_part(labels: Image) -> Part:
    """Instance ids per pixel (0 = none); an array becomes a 16-bit PNG."""
    if isinstance(labels, np.ndarray):
        if labels.size and (labels.min() < 0 or labels.max() > 65535):
            raise ValueError("labels must be instance ids in 0..65535")
        return Part("labels", encode_grey(labels.astype(np.uint16)), "labels.png", "image/png")
    return _file("labels", labels, "labels.png")


def depth_request(depth: Depth, intrinsics: Union[Intrinsics, None],
                  fields: Dict[str, str]) -> tuple:
    """(fields, parts) of a depth upload: the depth part, the camera, the options."""
    camera_fields, parts = intrinsics_parts(intrinsics)
    all_parts: List[Part] = [depth_part(depth)] + parts
    return {**camera_fields, **fields}, all_parts


def mesh_bytes(mesh: Union[str, "os.PathLike[str]", bytes]) -> bytes:
    """The mesh file's bytes (OBJ, PLY or STL), from its path or as given."""
    return _file("mesh", mesh, "mesh").data
