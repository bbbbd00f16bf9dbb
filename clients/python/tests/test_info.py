"""Client.info against the real servers, and what the client does when there is no server."""
from __future__ import annotations

import socket
import unittest

import softgrasp
from support import ServerTest, client, robot_client


class InfoTest(ServerTest):
    def test_server_with_models(self) -> None:
        info = client().info()
        self.assertEqual(info.name, "softgrasp")
        self.assertTrue(info.version)
        self.assertEqual({m.name for m in info.models}, {"pix2stiffness", "segmentation", "gqcnn"})
        self.assertEqual(set(info.strategies), {"fge", "stiffness", "deformability", "gqcnn"})
        self.assertEqual(info.default_strategy, "deformability")
        self.assertEqual(info.default_segmentation_method, "model")
        self.assertIn("npy", info.depth_formats)
        self.assertGreater(info.limits["max_body_bytes"], 0)
        self.assertIs(info.robot_enabled, False)
        self.assertIn("disabled", info.robot_reason)
        strategies = {s.name: s for s in info.strategy_fields}
        fields = {f.name: f for f in strategies["deformability"].fields}
        self.assertEqual(fields["num_slices"].kind, "integer")
        self.assertEqual(fields["num_slices"].default, info.defaults["deformability"]["num_slices"])
        self.assertEqual(fields["slice_step_mm"].unit, "mm")
        self.assertEqual(set(fields["target_policy"].choices), {"highest", "least_deformable"})

    def test_server_without_models(self) -> None:
        info = robot_client().info()
        self.assertEqual(info.models, [])
        self.assertEqual(info.strategies, ["fge"])
        self.assertEqual(info.default_strategy, "fge")
        self.assertIs(info.robot_enabled, True)

    def test_wrong_path_is_a_404_error(self) -> None:
        wrong = softgrasp.Client(client().url + "/no/such/prefix")
        self.assertRefused(404, "not_found", None, wrong.info)

    def test_no_server_is_an_os_error(self) -> None:
        with socket.socket() as s:  # a port nothing listens on once it is closed
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        with self.assertRaises(OSError):
            softgrasp.Client(f"http://127.0.0.1:{port}", timeout=5).info()


if __name__ == "__main__":
    unittest.main()
