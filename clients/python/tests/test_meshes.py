"""Client.mesh_grasps against the real server: POST /v1/meshes/grasps."""
from __future__ import annotations

import unittest

from support import MESH_FILE, ServerTest, client

OPTIONS = {"num_grasps": 20, "robust_samples": 5, "seed": 1}
OPEN_TRIANGLE = b"v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nf 1 2 3\n"


class MeshGraspsTest(ServerTest):
    def setUp(self) -> None:
        self.client = client()

    def test_bar_clamp(self) -> None:
        analysis = self.client.mesh_grasps(MESH_FILE, **OPTIONS)
        self.assertEqual((analysis.mesh.format, analysis.mesh.triangles), ("obj", 476))
        self.assertEqual(analysis.mesh.scale_applied, 1.0)
        extents = analysis.mesh.extents_m
        self.assertTrue(all(0.05 < e < 0.2 for e in extents), extents)
        self.assertTrue(analysis.stable_poses)
        probabilities = [p.probability for p in analysis.stable_poses]
        self.assertEqual(probabilities, sorted(probabilities, reverse=True))
        self.assertLessEqual(sum(probabilities), 1 + 1e-9)
        self.assertEqual(analysis.stable_poses[0].table_from_object.frame, "table")
        self.assertTrue(0 < len(analysis.grasps) <= 20)
        for grasp in analysis.grasps:
            self.assertEqual(len(grasp.contacts), 2)
            self.assertEqual([p.pose for p in grasp.poses], list(range(len(analysis.stable_poses))))
            self.assertIsNotNone(grasp.robust_ferrari_canny)
            self.assertTrue(0.0025 <= grasp.width_m <= 0.05 + 1e-9, grasp.width_m)
        usable = [p for g in analysis.grasps for p in g.poses if p.aligned and p.collision_free]
        self.assertTrue(usable)

    def test_bytes_and_path_give_the_same_analysis(self) -> None:
        with open(MESH_FILE, "rb") as f:
            from_bytes = self.client.mesh_grasps(f.read(), **OPTIONS)
        from_path = self.client.mesh_grasps(MESH_FILE, **OPTIONS)
        self.assertEqual(from_bytes, from_path)  # timings aside

    def test_options_reach_the_server(self) -> None:
        nominal = self.client.mesh_grasps(MESH_FILE, num_grasps=5, robust_samples=0, seed=1)
        self.assertTrue(all(g.robust_ferrari_canny is None for g in nominal.grasps))
        millimetres = self.client.mesh_grasps(MESH_FILE, unit="mm", rescale_min_extent_mm=40,
                                              num_grasps=5, robust_samples=0)
        self.assertEqual(millimetres.mesh.unit_scale_m, 0.001)
        self.assertNotEqual(millimetres.mesh.rescale_factor, 1.0)

    def test_refusals(self) -> None:
        self.assertRefused(415, "unsupported_media_type", "mesh", self.client.mesh_grasps,
                           b"hello, not a mesh")
        self.assertRefused(400, "invalid_argument", "unit", self.client.mesh_grasps, MESH_FILE,
                           unit="inch")
        self.assertRefused(400, "invalid_argument", "num_grasps", self.client.mesh_grasps,
                           MESH_FILE, num_grasps=0)
        error = self.assertRefused(422, "unprocessable", "mesh", self.client.mesh_grasps,
                                   OPEN_TRIANGLE)
        self.assertIn("not closed", error.message)


if __name__ == "__main__":
    unittest.main()
