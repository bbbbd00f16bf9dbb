"""The answer of ``POST /v1/grasps``: ranked two-finger grasps in one depth image.

Grasps are in pixels (``center_px``, ``opening_px``) and as a pose in the camera frame (OpenCV:
x right, y down, z forward; metres). The gripper approaches along the camera's +z; its closing
axis lies in the image plane at ``angle_rad`` from +u (image right) towards +v (image down).
Heights are metres above the fitted floor plane (table or bin bottom).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Tuple

from .common import Camera, ImageInfo, Pose, floats, optional_float


@dataclass(frozen=True)
class Gripper:
    """The two-finger gripper the grasps are planned for (millimetres, newtons)."""

    opening_stroke_mm: float
    finger_width_mm: float
    finger_thickness_mm: float
    finger_length_mm: float
    closing_force_n: float
    friction_coefficient: float
    max_press_force_n: float

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Gripper":
        return cls(*(float(d[name]) for name in cls.__dataclass_fields__))


@dataclass(frozen=True)
class DeformabilityDetail:
    """``strategy=deformability`` only: how Algorithm 1 found the grasp.

    ``slice`` 0 is the highest searched; ``opening_fraction`` of the stroke; mean deformability
    (0 rigid ... 1 very soft) under the fingers; soft neighbours pressed aside and how deep
    (metres)."""

    target_policy: str
    target_by: str
    slice: int
    opening_fraction: float
    mean_deformability: Optional[float]
    pressed_instances: Tuple[int, ...]
    press_depth_m: float

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "DeformabilityDetail":
        return cls(str(d["target_policy"]), str(d["target_by"]), int(d["slice"]),
                   float(d["opening_fraction"]), optional_float(d.get("mean_deformability")),
                   tuple(int(i) for i in d["pressed_instances"]), float(d["press_depth_m"]))


@dataclass(frozen=True)
class GqcnnDetail:
    """``strategy=gqcnn`` only: the network's probability of success (= the grasp's score),
    whether it clears the model's decision threshold, the jaws' depth (camera z, metres) and
    the contact check (``firm`` or ``stable``)."""

    predicted_quality: float
    predicted_success: bool
    grasp_depth_m: float
    contacts: str

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "GqcnnDetail":
        return cls(float(d["predicted_quality"]), bool(d["predicted_success"]),
                   float(d["grasp_depth_m"]), str(d["contacts"]))


@dataclass(frozen=True)
class Grasp:
    """One grasp, ``rank`` 1 = best.

    ``center_px`` is (u, v); ``opening_m`` the opening before closing; ``contact_height_m`` the
    height slice the fingers close on and ``grasp_height_m`` the fingertips' height, above the
    floor. ``mean_stiffness`` (0 soft ... 1 hard) is None when the stiffness model did not run;
    ``instance_id`` (0 = none) and ``instance_deformability`` are None unless the request used
    a segmentation. Pass a Grasp to ``Client.forward_grasp`` to send it to a robot."""

    rank: int
    score: float
    center_px: Tuple[float, float]
    angle_rad: float
    opening_px: float
    opening_m: float
    finger_width_px: float
    finger_thickness_px: float
    contact_height_m: float
    grasp_height_m: float
    height_step: int
    mean_stiffness: Optional[float]
    instance_id: Optional[int]
    instance_deformability: Optional[float]
    pose: Pose
    deformability: Optional[DeformabilityDetail] = None
    gqcnn: Optional[GqcnnDetail] = None

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Grasp":
        return cls(
            rank=int(d["rank"]), score=float(d["score"]),
            center_px=(float(d["center_px"]["u"]), float(d["center_px"]["v"])),
            angle_rad=float(d["angle_rad"]), opening_px=float(d["opening_px"]),
            opening_m=float(d["opening_m"]), finger_width_px=float(d["finger_width_px"]),
            finger_thickness_px=float(d["finger_thickness_px"]),
            contact_height_m=float(d["contact_height_m"]),
            grasp_height_m=float(d["grasp_height_m"]),
            height_step=int(d["height_step"]), mean_stiffness=optional_float(d["mean_stiffness"]),
            instance_id=None if d["instance_id"] is None else int(d["instance_id"]),
            instance_deformability=optional_float(d["instance_deformability"]),
            pose=Pose.from_json(d["pose"]),
            deformability=(DeformabilityDetail.from_json(d["deformability"])
                           if d.get("deformability") else None),
            gqcnn=GqcnnDetail.from_json(d["gqcnn"]) if d.get("gqcnn") else None,
        )


@dataclass(frozen=True)
class Target:
    """``strategy=deformability`` only: the object chosen (None when no candidate gave a grasp),
    the policy, the candidates tried in order, and whether the whole scene was planned instead
    (``fallback``) or the target's soft part allowed as contact."""

    id: Optional[int]
    policy: str
    tried: Tuple[int, ...]
    fallback: bool
    soft_part_allowed: bool

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Target":
        return cls(None if d["id"] is None else int(d["id"]), str(d["policy"]),
                   tuple(int(i) for i in d["tried"]), bool(d["fallback"]),
                   bool(d["soft_part_allowed"]))


@dataclass(frozen=True)
class GraspResult:
    """The whole answer: grasps best first, and what they were planned with.

    ``floor_normal`` and ``floor_d_m`` are the floor plane n . p + d = 0 in the camera frame (n
    towards the camera). ``segmask``, ``min_depth_m`` and ``contact_target`` say where contacts
    were allowed. ``segmentation_source`` (labels, model, pcl, fused) and
    ``segmentation_instances`` are None unless instances were asked for. ``timing_ms`` holds
    the server's stage times in milliseconds. ``raw`` is the JSON answer as parsed."""

    strategy: str
    grasps: List[Grasp]
    image: ImageInfo
    camera: Camera
    gripper: Gripper
    floor_normal: Tuple[float, ...]
    floor_d_m: float
    segmask: bool
    min_depth_m: float
    contact_target: Optional[int]
    stiffness_model: Optional[str]
    target: Optional[Target]
    segmentation_source: Optional[str]
    segmentation_instances: Optional[int]
    timing_ms: Dict[str, float]
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Dict[str, Any]) -> "GraspResult":
        region = d["contact_region"]
        segmentation = d.get("segmentation")
        return cls(
            strategy=str(d["strategy"]), grasps=[Grasp.from_json(g) for g in d["grasps"]],
            image=ImageInfo.from_json(d["image"]), camera=Camera.from_json(d["camera"]),
            gripper=Gripper.from_json(d["gripper"]),
            floor_normal=floats(d["floor"]["normal"]), floor_d_m=float(d["floor"]["d_m"]),
            segmask=bool(region["segmask"]), min_depth_m=float(region["min_depth_m"]),
            contact_target=region.get("target"), stiffness_model=d.get("stiffness_model"),
            target=Target.from_json(d["target"]) if d.get("target") else None,
            segmentation_source=segmentation["source"] if segmentation else None,
            segmentation_instances=int(segmentation["instances"]) if segmentation else None,
            timing_ms={k: float(v) for k, v in d["timing_ms"].items()}, raw=d,
        )
