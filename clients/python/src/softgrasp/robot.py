"""Grasps forwarded to a robot: ``POST /v1/robot/grasps`` and ``GET /v1/robot/grasps/{id}``.

Positions are metres and orientations unit quaternions (w, x, y, z) in the workspace's frame
(``camera`` by default, the frame grasps come in); openings and widths metres, forces newtons,
times seconds (``_unix_s``: seconds since 1970).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Mapping, Optional, Tuple, Union

from .common import floats, optional_float
from .grasps import Grasp

#: States after which a command no longer changes (its result, if any, is there).
FINAL_STATES = frozenset({"succeeded", "failed", "rejected", "timed_out"})


@dataclass(frozen=True)
class CommandSpec:
    """The command as the service states it, defaults filled in."""

    id: str
    robot_id: str
    object_id: str
    frame_id: str
    position_m: Tuple[float, ...]
    orientation_wxyz: Tuple[float, ...]
    opening_m: float
    force_n: float
    approach_m: float
    retreat_m: float
    score: float

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "CommandSpec":
        return cls(str(d["id"]), str(d["robot_id"]), str(d["object_id"]), str(d["frame_id"]),
                   floats(d["position_m"]), floats(d["orientation_wxyz"]), float(d["opening_m"]),
                   float(d["force_n"]), float(d["approach_m"]), float(d["retreat_m"]),
                   float(d["score"]))


@dataclass(frozen=True)
class RobotResult:
    """What the robot did: ``outcome`` and ``reason``; the finger opening at first contact
    (``contact_width_m``, l_c) and once the closing force was reached (``grasped_width_m``,
    l_g); ``deformation_rate`` (l_c - l_g) / l_c; the robot's and the service's clocks; ``late``
    when it came after the command had timed out."""

    command_id: str
    robot_id: str
    object_id: str
    outcome: str
    reason: str
    contact_width_m: float
    grasped_width_m: float
    deformation_rate: float
    execution_s: float
    finished_unix_ns: int
    finished_unix_s: float
    received_unix_s: float
    round_trip_s: float
    late: bool

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "RobotResult":
        return cls(str(d["command_id"]), str(d["robot_id"]), str(d["object_id"]),
                   str(d["outcome"]), str(d["reason"]), float(d["contact_width_m"]),
                   float(d["grasped_width_m"]), float(d["deformation_rate"]),
                   float(d["execution_s"]), int(d["finished_unix_ns"]),
                   float(d["finished_unix_s"]), float(d["received_unix_s"]),
                   float(d["round_trip_s"]), bool(d["late"]))


@dataclass(frozen=True)
class RobotCommand:
    """A forwarded grasp and where it stands.

    ``state``: queued, sent, executing, or one of FINAL_STATES (succeeded, failed, rejected,
    timed_out). ``result`` is None until the robot answers; ``detail`` says why a command is
    still queued or why it timed out. ``http_status`` is 202 for a new command, 200 for a repeat
    of one already accepted (the same id never moves a robot twice) and for reads."""

    id: str
    state: str
    robot_id: str
    object_id: str
    accepted_unix_s: float
    command: CommandSpec
    result: Optional[RobotResult]
    detail: Optional[str]
    timed_out_unix_s: Optional[float]
    http_status: int
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @property
    def finished(self) -> bool:
        return self.state in FINAL_STATES

    @classmethod
    def from_json(cls, d: Dict[str, Any], http_status: int) -> "RobotCommand":
        return cls(str(d["id"]), str(d["state"]), str(d["robot_id"]), str(d["object_id"]),
                   float(d["accepted_unix_s"]), CommandSpec.from_json(d["command"]),
                   RobotResult.from_json(d["result"]) if d.get("result") else None,
                   d.get("detail"), optional_float(d.get("timed_out_unix_s")), http_status, d)


def command_body(command_id: str, grasp: Union[Grasp, Mapping[str, Any]],
                 options: Mapping[str, Any]) -> Dict[str, Any]:
    """The JSON body: the grasp's pose, opening and score, the id and the options that are set.
    ``grasp`` is a Grasp or a grasp as the JSON answer has it (a dict with ``pose``,
    ``opening_m`` and optionally ``score``)."""
    if isinstance(grasp, Grasp):
        pose = {"frame": grasp.pose.frame, "position_m": list(grasp.pose.position_m),
                "orientation_wxyz": list(grasp.pose.orientation_wxyz)}
        body: Dict[str, Any] = {"pose": pose, "opening_m": grasp.opening_m, "score": grasp.score}
    else:
        body = {key: grasp[key] for key in ("pose", "opening_m", "score") if key in grasp}
    body["id"] = command_id
    body.update({key: value for key, value in options.items() if value is not None})
    return body
