"""Client.forward_grasp and Client.robot_command against the real servers.

Without a robot: the robot routes turned off (503), and with them on, every refusal the service
checks before a robot is needed (401, 403, 400, 422, 404), then no such robot alive (503 with
Retry-After). With the simulated robot (softgrasp-sim robot on the robot server's bus): a grasp
planned on its camera image, forwarded, followed to a final state, repeated (200) and reused
with another grasp (409).
"""
from __future__ import annotations

import io
import json
import os
import secrets
import time
import unittest
import urllib.request

import numpy as np

import softgrasp
from support import INTRINSICS_FILE, SIM_URL, ServerTest, client, depth, robot_client

SIM_ROBOT_ID = os.environ.get("SOFTGRASP_SIM_ROBOT_ID", "sim-python")
FOLLOW_TIMEOUT_S = 40.0  # the robot server's command timeout is 20 s


def planned() -> softgrasp.GraspResult:
    """The best FGE grasp on Primesense frame 0 (camera frame, inside the default workspace)."""
    return client().grasps(depth(), intrinsics=INTRINSICS_FILE, strategy="fge", top_k=1)


def new_id() -> str:
    return "python-" + secrets.token_hex(6)


class RobotRoutesOffTest(ServerTest):
    def test_forward_and_read_are_503(self) -> None:
        c = softgrasp.Client(client().url, robot_token="any-token-0123456789")
        error = self.assertRefused(503, "service_unavailable", None, c.forward_grasp, new_id(),
                                   planned().grasps[0])
        self.assertIn("disabled", error.message)
        self.assertIsNone(error.retry_after)
        self.assertRefused(503, "service_unavailable", None, c.robot_command, "any-id")


class RobotRefusalsTest(ServerTest):
    def setUp(self) -> None:
        self.robot = robot_client()
        self.planned = planned()
        self.grasp = self.planned.grasps[0]

    def test_no_such_robot_is_503_with_retry_after(self) -> None:
        error = self.assertRefused(503, "service_unavailable", None, self.robot.forward_grasp,
                                   new_id(), self.grasp, robot_id="nobody-here")
        self.assertEqual(error.retry_after, 2)

    def test_a_grasp_as_json_is_sent_as_well(self) -> None:
        as_json = self.planned.raw["grasps"][0]  # the grasp as POST /v1/grasps answers it
        self.assertRefused(503, "service_unavailable", None, self.robot.forward_grasp, new_id(),
                           as_json, robot_id="nobody-here")

    def test_token(self) -> None:
        self.assertRefused(401, "unauthorized", "Authorization", robot_client(None).forward_grasp,
                           new_id(), self.grasp)
        self.assertRefused(403, "forbidden", "Authorization",
                           robot_client("wrong-token-0123456789").robot_command, "any-id")

    def test_bad_fields_name_the_field(self) -> None:
        self.assertRefused(400, "invalid_argument", "id", self.robot.forward_grasp, "not an id!",
                           self.grasp)
        self.assertRefused(422, "unprocessable", "force_n", self.robot.forward_grasp, new_id(),
                           self.grasp, force_n=0)
        tilted = {"pose": {"frame": "camera", "position_m": [0, 0, 0.5],
                           "orientation_wxyz": [2, 0, 0, 0]}, "opening_m": 0.05}
        self.assertRefused(422, "unprocessable", "pose.orientation_wxyz",
                           self.robot.forward_grasp, new_id(), tilted)
        far = {**tilted, "pose": {**tilted["pose"], "position_m": [0, 0, 5],
                                  "orientation_wxyz": [1, 0, 0, 0]}}
        self.assertRefused(422, "unprocessable", "pose.position_m", self.robot.forward_grasp,
                           new_id(), far)

    def test_unknown_command_is_404(self) -> None:
        self.assertRefused(404, "not_found", "id", self.robot.robot_command, "never-sent")


def fetch(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=30) as answer:
        return answer.read()


class SimulatedRobotTest(ServerTest):
    def setUp(self) -> None:
        if not SIM_URL:
            raise unittest.SkipTest("no simulated robot: softgrasp-sim is not built")
        self.robot = robot_client()

    def wait_for_robot(self) -> None:
        """Until the service hears the robot (DDS discovery takes a moment)."""
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:
            listed = json.loads(fetch(self.robot.url + "/v1/robot"))
            if any(r["robot_id"] == SIM_ROBOT_ID and r["alive"] for r in listed["robots"]):
                return
            time.sleep(0.1)
        self.fail(f"the service does not hear {SIM_ROBOT_ID}")

    def test_forward_follow_repeat(self) -> None:
        self.wait_for_robot()
        image = np.load(io.BytesIO(fetch(SIM_URL + "/depth.npy")))
        camera = fetch(SIM_URL + "/camera.intr")
        grasps = self.robot.grasps(image, intrinsics=camera, top_k=2).grasps
        self.assertEqual(len(grasps), 2)
        command_id = new_id()

        sent = self.robot.forward_grasp(command_id, grasps[0], object_id="python-test")
        self.assertEqual(sent.http_status, 202)
        self.assertEqual((sent.id, sent.robot_id, sent.object_id),
                         (command_id, SIM_ROBOT_ID, "python-test"))
        self.assertEqual(sent.command.position_m, grasps[0].pose.position_m)
        self.assertEqual(sent.command.opening_m, grasps[0].opening_m)
        self.assertEqual(sent.command.force_n, 10.0)  # robot.default_force_n
        self.assertIn(sent.state, ("queued", "sent", "executing", *softgrasp.FINAL_STATES))

        deadline = time.monotonic() + FOLLOW_TIMEOUT_S
        command = self.robot.robot_command(command_id)
        while not command.finished and time.monotonic() < deadline:
            time.sleep(0.2)
            command = self.robot.robot_command(command_id)
        self.assertTrue(command.finished, command.state)
        self.assertEqual(command.http_status, 200)
        self.assertIsNotNone(command.result, command.detail)
        self.assertEqual(command.result.command_id, command_id)
        self.assertEqual(command.result.outcome, command.state)
        self.assertTrue(command.result.reason)

        repeat = self.robot.forward_grasp(command_id, grasps[0], object_id="python-test")
        self.assertEqual((repeat.http_status, repeat.state), (200, command.state))
        self.assertRefused(409, "conflict", "id", self.robot.forward_grasp, command_id, grasps[1],
                           object_id="python-test")


if __name__ == "__main__":
    unittest.main()
