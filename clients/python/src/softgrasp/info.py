"""The answer of ``GET /v1/info``: version, limits, loaded models, strategies and defaults."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Tuple

from .common import optional_float


@dataclass(frozen=True)
class ModelInfo:
    """A loaded model: ``name`` (pix2stiffness, segmentation, gqcnn), ``kind`` (stiffness,
    segmentation, grasp_quality), its size in parameters and a one-line description."""

    name: str
    kind: str
    parameters: int
    description: str

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "ModelInfo":
        return cls(str(d["name"]), str(d["kind"]), int(d["parameters"]), str(d["description"]))


@dataclass(frozen=True)
class StrategyField:
    """A request field of a strategy: ``kind`` number, integer, choice or number_list;
    ``unit`` mm, px or empty; its default, range and, for a choice, the names allowed. Pass it
    to ``Client.grasps`` as a keyword (a number_list as a list)."""

    name: str
    kind: str
    unit: str
    default: Any
    doc: str
    minimum: Optional[float] = None
    maximum: Optional[float] = None
    choices: Tuple[str, ...] = ()

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "StrategyField":
        return cls(str(d["name"]), str(d["kind"]), str(d["unit"]), d["default"], str(d["doc"]),
                   optional_float(d.get("minimum")), optional_float(d.get("maximum")),
                   tuple(d.get("choices", ())))


@dataclass(frozen=True)
class StrategyInfo:
    """A registered strategy (served or not: see ``Info.strategies``), the models it needs and
    its own request fields."""

    name: str
    summary: str
    needs_models: Tuple[str, ...]
    plans_target: bool
    fields: Tuple[StrategyField, ...]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "StrategyInfo":
        return cls(str(d["name"]), str(d["summary"]), tuple(d["needs_models"]),
                   bool(d["plans_target"]), tuple(StrategyField.from_json(f) for f in d["fields"]))


@dataclass(frozen=True)
class Info:
    """What the server is and serves. ``strategies`` are the ones it serves now (with the models
    it loaded); ``limits`` and ``defaults`` are the JSON objects as they come (bytes, pixels,
    milliseconds; the request defaults, each strategy's under its name). ``robot_enabled`` says
    whether the robot routes serve, ``robot_reason`` why not."""

    name: str
    version: str
    build: Dict[str, Any]
    limits: Dict[str, Any]
    models: List[ModelInfo]
    strategies: List[str]
    default_strategy: str
    strategy_fields: List[StrategyInfo]
    segmentation_methods: List[str]
    default_segmentation_method: str
    depth_formats: List[str]
    defaults: Dict[str, Any]
    robot_enabled: Optional[bool]
    robot_reason: Optional[str]
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Dict[str, Any]) -> "Info":
        robot = d.get("robot") or {}
        return cls(str(d["name"]), str(d["version"]), dict(d["build"]), dict(d["limits"]),
                   [ModelInfo.from_json(m) for m in d["models"]], list(d["strategies"]),
                   str(d["default_strategy"]),
                   [StrategyInfo.from_json(s) for s in d["strategy_fields"]],
                   list(d["segmentation_methods"]), str(d["default_segmentation_method"]),
                   list(d["depth_formats"]), dict(d["defaults"]), robot.get("enabled"),
                   robot.get("reason"), d)
