"""Python client of softgrasp, the grasp-planning service: numpy arrays in, dataclasses out.

    import numpy as np, softgrasp
    client = softgrasp.Client("http://127.0.0.1:8080")
    result = client.grasps(np.load("depth.npy"), intrinsics="camera.intr", top_k=3)
    best = result.grasps[0]          # best.pose.position_m: metres, camera frame

Units and frames are the service's: metres and radians unless a name ends in ``_mm`` or ``_px``;
the camera frame is OpenCV's (x right, y down, z forward); pixels are (u, v) = (column, row);
quaternions (w, x, y, z). Every refused request raises SoftgraspError.
"""
from .client import Client
from .common import Camera, ImageInfo, Pose
from .errors import SoftgraspError
from .grasps import DeformabilityDetail, GqcnnDetail, Grasp, GraspResult, Gripper, Target
from .info import Info, ModelInfo, StrategyField, StrategyInfo
from .meshes import Contact, GraspInPose, MeshGrasp, MeshGraspAnalysis, MeshInfo, StablePose
from .robot import FINAL_STATES, CommandSpec, RobotCommand, RobotResult
from .segmentation import Instance, Segmentation

__version__ = "0.1.0"

__all__ = [
    "Client", "SoftgraspError",
    "Camera", "ImageInfo", "Pose",
    "Grasp", "GraspResult", "Gripper", "DeformabilityDetail", "GqcnnDetail", "Target",
    "Instance", "Segmentation",
    "MeshGraspAnalysis", "MeshInfo", "MeshGrasp", "StablePose", "Contact", "GraspInPose",
    "RobotCommand", "CommandSpec", "RobotResult", "FINAL_STATES",
    "Info", "ModelInfo", "StrategyInfo", "StrategyField",
]
