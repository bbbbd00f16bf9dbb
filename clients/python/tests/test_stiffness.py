"""Client.stiffness against the real server: POST /v1/stiffness."""
from __future__ import annotations

import unittest

import numpy as np

from support import INTRINSICS_FILE, ServerTest, client, depth, robot_client


class StiffnessTest(ServerTest):
    def setUp(self) -> None:
        self.client = client()
        self.depth = depth()

    def test_map_has_the_depths_size(self) -> None:
        stiffness = self.client.stiffness(self.depth, intrinsics=INTRINSICS_FILE)
        self.assertEqual(stiffness.dtype, np.float32)
        self.assertEqual(stiffness.shape, (480, 640))
        self.assertGreaterEqual(float(stiffness.min()), 0.0)
        self.assertLessEqual(float(stiffness.max()), 1.0)
        # Mostly table (0 = background), and objects on it (0.1 soft ... 1 hard).
        self.assertGreater(np.mean(stiffness == 0), 0.5)
        self.assertGreater(np.count_nonzero(stiffness > 0.5), 1000)

    def test_same_frame_same_map(self) -> None:
        a = self.client.stiffness(self.depth)
        b = self.client.stiffness(self.depth[:, :, 0])  # (H, W) instead of (H, W, 1)
        np.testing.assert_allclose(a, b, atol=1e-6)

    def test_refusals(self) -> None:
        self.assertRefused(400, "invalid_argument", "png_unit_m", self.client.stiffness,
                           self.depth, png_unit_m=0)
        self.assertRefused(415, "unsupported_media_type", "depth", self.client.stiffness,
                           b"\x89PNG not really")
        with self.assertRaises(TypeError):
            self.client.stiffness(self.depth, format="png8")

    def test_no_model_is_503(self) -> None:
        error = self.assertRefused(503, "service_unavailable", "model",
                                   robot_client().stiffness, self.depth)
        self.assertIn("stiffness model", error.message)


if __name__ == "__main__":
    unittest.main()
