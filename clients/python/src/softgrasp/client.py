"""The client: one method per call of the softgrasp API (openapi.yaml)."""
from __future__ import annotations

import io
import json
import os
import urllib.parse
from typing import Any, Dict, Mapping, Optional, Sequence, Union

import numpy as np

from . import _inputs
from ._http import Part, Response, form_fields, multipart, send
from ._inputs import Depth, Image, Intrinsics
from ._png import decode_grey
from .grasps import Grasp, GraspResult
from .info import Info
from .meshes import MeshGraspAnalysis
from .robot import RobotCommand, command_body
from .segmentation import Segmentation


class Client:
    """A softgrasp server at ``url``.

    ``timeout`` is seconds per request (connecting and each read). ``robot_token`` is a token of
    the server's ``robot.tokens``, sent as ``Authorization: Bearer ...`` on the robot calls only.
    A 4xx/5xx answer raises SoftgraspError; a server that cannot be reached raises OSError.
    """

    def __init__(self, url: str = "http://127.0.0.1:8080", *, timeout: float = 60.0,
                 robot_token: Optional[str] = None) -> None:
        self.url = url.rstrip("/")
        self.timeout = timeout
        self.robot_token = robot_token

    def __repr__(self) -> str:
        return f"Client({self.url!r})"

    # -- plumbing --------------------------------------------------------------------------------

    def _send(self, method: str, path: str, body: Optional[bytes] = None,
              headers: Optional[Mapping[str, str]] = None) -> Response:
        return send(method, self.url + path, body=body, headers=headers, timeout=self.timeout)

    def _depth_upload(self, path: str, depth: Depth, intrinsics: Optional[Intrinsics],
                      options: Mapping[str, Any], answer: Mapping[str, str], accept: str,
                      extra_parts: Sequence[Part] = ()) -> Response:
        """A depth upload as multipart/form-data: the caller's options, then ``answer`` (the
        format fields the client chooses itself, so that it can parse what comes back)."""
        chosen = sorted(name for name in answer if options.get(name) is not None)
        if chosen:
            raise TypeError(f"{', '.join(chosen)} is chosen by the client; leave it out")
        fields, parts = _inputs.depth_request(depth, intrinsics, {**form_fields(options), **answer})
        body, content_type = multipart(fields, [*parts, *extra_parts])
        return self._send("POST", path, body, {"Content-Type": content_type, "Accept": accept})

    def _robot_headers(self) -> Dict[str, str]:
        return {"Authorization": f"Bearer {self.robot_token}"} if self.robot_token else {}

    # -- the calls -------------------------------------------------------------------------------

    def info(self) -> Info:
        """``GET /v1/info``: version, build, limits, loaded models, strategies and their fields,
        request defaults, whether the robot routes serve."""
        return Info.from_json(self._send("GET", "/v1/info").json())

    def grasps(self, depth: Depth, *, intrinsics: Optional[Intrinsics] = None,
               strategy: Optional[str] = None, top_k: Optional[int] = None,
               segmask: Optional[Image] = None, labels: Optional[Image] = None,
               target: Optional[int] = None, **fields: Any) -> GraspResult:
        """``POST /v1/grasps``: ranked two-finger grasps in a depth image.

        Args:
            depth: float32/float64 array in metres or uint16 array in millimetres, shape (H, W)
                or (H, W, 1), 0 or NaN = no reading (sent as .npy); or an NPY, 16-bit PNG or
                float TIFF file, by path or as bytes.
            intrinsics: the camera: a Camera (fx, fy, cx, cy in pixels), a dict in any layout
                the server reads (GQ-CNN .intr, ROS CameraInfo, Open3D, librealsense), or such a
                JSON file by path or bytes. None: the server's default camera.
            strategy: fge, stiffness, deformability or gqcnn (``Info.strategies``); None: the
                server's default.
            top_k: how many grasps at most (1..100).
            segmask: where contacts may be: a (H, W) array, non-zero = allowed (sent as a PNG),
                or a PNG file by path or bytes.
            labels: instance ids per pixel, 0 = none, e.g. ``Segmentation.labels`` (sent as a
                16-bit PNG); used instead of segmenting the scene.
            target: only grasps with contacts on this instance id.
            **fields: any other request field of openapi.yaml, e.g. the strategy's own
                (``Info.strategy_fields``: ``num_slices=5``, ``opening_fractions=[0.5, 1]``),
                the gripper's (``opening_stroke_mm=50``), ``min_depth_m=0.6``,
                ``instances=True``, ``target_px=(320, 240)``. Booleans go as true/false,
                lists comma-separated; None leaves a field out.

        Returns:
            GraspResult, grasps best first; poses in the camera frame, metres.
        """
        options = {"strategy": strategy, "top_k": top_k, "target": target, **fields}
        parts = []
        if segmask is not None:
            parts.append(_inputs.segmask_part(segmask))
        if labels is not None:
            parts.append(_inputs.labels_part(labels))
        answer = self._depth_upload("/v1/grasps", depth, intrinsics, options, {"format": "json"},
                                    "application/json", parts)
        return GraspResult.from_json(answer.json())

    def stiffness(self, depth: Depth, *, intrinsics: Optional[Intrinsics] = None,
                  **fields: Any) -> np.ndarray:
        """``POST /v1/stiffness``: the pix2stiffness model's map of a depth image.

        ``depth`` and ``intrinsics`` as for ``grasps``; ``fields`` e.g. ``png_unit_m``.
        Returns a float32 array of the depth's height x width: 1 = hard, 0.1 = the softest
        objects, 0 = background (floor, bin). 503 when the server has no stiffness model.
        """
        answer = self._depth_upload("/v1/stiffness", depth, intrinsics, fields, {"format": "npy"},
                                    "application/x-npy")
        return np.load(io.BytesIO(answer.body), allow_pickle=False)

    def segmentation(self, depth: Depth, *, intrinsics: Optional[Intrinsics] = None,
                     method: Optional[str] = None, labels: bool = True,
                     **fields: Any) -> Segmentation:
        """``POST /v1/segmentation``: the object instances of a depth image.

        ``depth`` and ``intrinsics`` as for ``grasps``. ``method``: model (the default when the
        server has the model), pcl (the geometric baseline, no deformability) or fused.
        ``labels``: also fetch the label image (a second request, ``format=labels``: the server
        segments the same frame again and gives the same ids). Returns the instances, best score
        first, and the labels as a uint16 (H, W) array, 0 = background.
        """
        options = {"method": method, **fields}
        answer = self._depth_upload("/v1/segmentation", depth, intrinsics, options,
                                    {"format": "json"}, "application/json")
        label_image = None
        if labels:
            png = self._depth_upload("/v1/segmentation", depth, intrinsics, options,
                                     {"format": "labels"}, "image/png")
            label_image = decode_grey(png.body)
        return Segmentation.from_json(answer.json(), label_image)

    def mesh_grasps(self, mesh: Union[str, "os.PathLike[str]", bytes], *,
                    unit: Optional[str] = None, num_grasps: Optional[int] = None,
                    robust_samples: Optional[int] = None, seed: Optional[int] = None,
                    **options: Any) -> MeshGraspAnalysis:
        """``POST /v1/meshes/grasps``: stable poses and antipodal grasps of one rigid mesh.

        Args:
            mesh: an OBJ, PLY or STL file, by path or as bytes (the format is sniffed).
            unit: the file's length unit, m (default) or mm.
            num_grasps: grasps sampled at most (default 100).
            robust_samples: noise draws of the robust Ferrari-Canny (default 25, 0 = skip).
            seed: sampling seed: the same file and options give the same answer.
            **options: any other option of openapi.yaml, e.g. ``rescale_min_extent_mm=40``,
                ``friction_coefficient=0.5``, ``max_approach_angle_deg=5``.

        Returns:
            MeshGraspAnalysis: vectors in the prepared mesh's frame, metres; grasps best first.
        """
        query = form_fields({"unit": unit, "num_grasps": num_grasps,
                             "robust_samples": robust_samples, "seed": seed, **options})
        if "format" in query:
            raise TypeError("format is chosen by the client; leave it out")
        query["format"] = "json"
        answer = self._send("POST", "/v1/meshes/grasps?" + urllib.parse.urlencode(query),
                            _inputs.mesh_bytes(mesh),
                            {"Content-Type": "application/octet-stream",
                             "Accept": "application/json"})
        return MeshGraspAnalysis.from_json(answer.json())

    def forward_grasp(self, command_id: str, grasp: Union[Grasp, Mapping[str, Any]], *,
                      force_n: Optional[float] = None, approach_m: Optional[float] = None,
                      retreat_m: Optional[float] = None, robot_id: Optional[str] = None,
                      object_id: Optional[str] = None,
                      frame_id: Optional[str] = None) -> RobotCommand:
        """``POST /v1/robot/grasps``: send a grasp to a robot (needs ``robot_token``).

        Args:
            command_id: your id for the command, ``[A-Za-z0-9._-]{1,64}``. The same id never
                moves a robot twice: a repeat with the same grasp answers the command as it
                stands (``http_status`` 200); with another grasp it is a 409.
            grasp: a Grasp from ``grasps()`` (or its JSON dict): its pose (camera frame,
                metres, quaternion w, x, y, z), ``opening_m`` and ``score`` are sent.
            force_n: closing force, (0, 1000] N; default the server's robot.default_force_n.
            approach_m, retreat_m: [0, 1] m, default 0.1.
            robot_id: which robot; default the only one alive.
            object_id: passed on to the robot.
            frame_id: must be the workspace's frame (default camera).

        Returns:
            RobotCommand, ``http_status`` 202 when newly accepted. No robot alive is a 503 with
            ``retry_after`` set; robot routes turned off are a 503 without.
        """
        body = command_body(command_id, grasp, {
            "force_n": force_n, "approach_m": approach_m, "retreat_m": retreat_m,
            "robot_id": robot_id, "object_id": object_id, "frame_id": frame_id})
        answer = self._send("POST", "/v1/robot/grasps", json.dumps(body).encode(),
                            {"Content-Type": "application/json", **self._robot_headers()})
        return RobotCommand.from_json(answer.json(), answer.status)

    def robot_command(self, command_id: str) -> RobotCommand:
        """``GET /v1/robot/grasps/{id}``: a forwarded grasp's state and, once the robot answered,
        its result (needs ``robot_token``; 404 for an id the server does not know)."""
        path = "/v1/robot/grasps/" + urllib.parse.quote(command_id, safe="")
        answer = self._send("GET", path, None, self._robot_headers())
        return RobotCommand.from_json(answer.json(), answer.status)
