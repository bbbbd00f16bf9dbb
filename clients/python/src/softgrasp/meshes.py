"""The answer of ``POST /v1/meshes/grasps``: Dex-Net 2.0 style grasps on one rigid mesh.

Vectors are in the prepared mesh's frame O (file coordinates x ``mesh.scale_applied``), metres;
poses of the object and of the gripper on the table are in the frame "table".
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Tuple

from .common import Pose, floats, optional_float


@dataclass(frozen=True)
class MeshInfo:
    """The mesh as read and prepared: file format, size, the scale applied (prepared =
    file x ``scale_applied``), principal extents (metres), volume (cubic metres) and the
    repairs made."""

    format: str
    vertices: int
    triangles: int
    unit_scale_m: float
    rescale_factor: float
    scale_applied: float
    extents_m: Tuple[float, ...]
    volume_m3: float
    repairs: Tuple[str, ...]
    warnings: Tuple[str, ...]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "MeshInfo":
        return cls(str(d["format"]), int(d["vertices"]), int(d["triangles"]),
                   float(d["unit_scale_m"]), float(d["rescale_factor"]), float(d["scale_applied"]),
                   floats(d["extents_m"]), float(d["volume_m3"]), tuple(d["repairs"]),
                   tuple(d["warnings"]))


@dataclass(frozen=True)
class StablePose:
    """A resting pose on the table, most probable first: the object's pose in the table frame,
    the resting face's normal in O, the centre of mass' height (metres)."""

    index: int
    probability: float
    table_from_object: Pose
    face_normal_o: Tuple[float, ...]
    com_height_m: float
    num_face_vertices: int

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "StablePose":
        return cls(int(d["index"]), float(d["probability"]), Pose.from_json(d["table_from_object"]),
                   floats(d["face_normal_o"]), float(d["com_height_m"]),
                   int(d["num_face_vertices"]))


@dataclass(frozen=True)
class Contact:
    """Where a jaw touches the surface (O, metres) and the surface normal pointing inwards."""

    point_m: Tuple[float, ...]
    inward_normal: Tuple[float, ...]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Contact":
        return cls(floats(d["point_m"]), floats(d["inward_normal"]))


@dataclass(frozen=True)
class GraspInPose:
    """A mesh grasp seen in one stable pose: whether its top-down approach is within the
    allowed angle of vertical (``aligned``), whether a gripper reaches it without touching the
    object or the table (``collision_free``, at ``approach_offset_deg``, None when no offset
    worked), and the gripper's pose in the table frame."""

    pose: int
    aligned: bool
    approach_table_angle_deg: float
    collision_free: bool
    approach_offset_deg: Optional[float]
    approach_o: Tuple[float, ...]
    table_from_gripper: Pose

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "GraspInPose":
        return cls(int(d["pose"]), bool(d["aligned"]), float(d["approach_table_angle_deg"]),
                   bool(d["collision_free"]), optional_float(d["approach_offset_deg"]),
                   floats(d["approach_o"]), Pose.from_json(d["table_from_gripper"]))


@dataclass(frozen=True)
class MeshGrasp:
    """An antipodal jaw grasp, best first: centre and closing axis in O, jaw width (metres),
    its two contacts, Ferrari-Canny quality and its robust mean (None with robust_samples=0),
    and one GraspInPose per stable pose, in the same order."""

    rank: int
    sample_index: int
    center_m: Tuple[float, ...]
    axis: Tuple[float, ...]
    width_m: float
    contacts: Tuple[Contact, ...]
    ferrari_canny: float
    robust_ferrari_canny: Optional[float]
    poses: Tuple[GraspInPose, ...]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "MeshGrasp":
        return cls(int(d["rank"]), int(d["sample_index"]), floats(d["center_m"]),
                   floats(d["axis"]), float(d["width_m"]),
                   tuple(Contact.from_json(c) for c in d["contacts"]), float(d["ferrari_canny"]),
                   optional_float(d["robust_ferrari_canny"]),
                   tuple(GraspInPose.from_json(p) for p in d["poses"]))


@dataclass(frozen=True)
class MeshGraspAnalysis:
    """The whole analysis; ``timing_ms`` the server's stage times, ``raw`` the JSON answer."""

    mesh: MeshInfo
    center_of_mass_m: Tuple[float, ...]
    stable_poses: List[StablePose]
    grasps: List[MeshGrasp]
    timing_ms: Dict[str, float] = field(compare=False)
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Dict[str, Any]) -> "MeshGraspAnalysis":
        return cls(MeshInfo.from_json(d["mesh"]), floats(d["center_of_mass_m"]),
                   [StablePose.from_json(p) for p in d["stable_poses"]],
                   [MeshGrasp.from_json(g) for g in d["grasps"]],
                   {k: float(v) for k, v in d["timing_ms"].items()}, d)
