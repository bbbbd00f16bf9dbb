"""Client.grasps against the real server: POST /v1/grasps."""
from __future__ import annotations

import json
import math
import unittest

import numpy as np

import softgrasp
from support import DEPTH_FILE, INTRINSICS_FILE, SEGMASK_FILE, ServerTest, client, depth

PRIMESENSE = softgrasp.Camera(fx=525.0, fy=525.0, cx=319.5, cy=239.5, width=640, height=480)


class GraspsTest(ServerTest):
    def setUp(self) -> None:
        self.client = client()
        self.depth = depth()

    def test_fge_grasps_from_an_array(self) -> None:
        result = self.client.grasps(self.depth, intrinsics=INTRINSICS_FILE, strategy="fge", top_k=3)
        self.assertEqual(result.strategy, "fge")
        self.assertEqual(result.camera,
                         softgrasp.Camera(525.0, 525.0, 319.5, 239.5, 640, 480, "request"))
        image = result.image
        self.assertEqual((image.width, image.height, image.format), (640, 480, "npy"))
        self.assertTrue(1 <= len(result.grasps) <= 3)
        self.assertEqual([g.rank for g in result.grasps], list(range(1, len(result.grasps) + 1)))
        for grasp in result.grasps:
            self.assertEqual(grasp.pose.frame, "camera")
            x, y, z = grasp.pose.position_m
            self.assertTrue(0.5 < z < 0.8, z)  # the table is about 0.7 m from the camera
            self.assertAlmostEqual(math.hypot(*grasp.pose.orientation_wxyz), 1.0, places=6)
            self.assertTrue(0 <= grasp.angle_rad < math.pi)
            self.assertTrue(0 < grasp.opening_m <= result.gripper.opening_stroke_mm / 1000 + 1e-9)
            u, v = grasp.center_px
            self.assertTrue(0 <= u < 640 and 0 <= v < 480)
            self.assertIsNone(grasp.mean_stiffness)  # fge without mean_stiffness=true
            self.assertIsNone(grasp.instance_id)
            self.assertIsNone(grasp.deformability)
        self.assertEqual(len(result.floor_normal), 3)
        self.assertGreater(result.timing_ms["total"], 0)
        self.assertEqual(result.raw["strategy"], "fge")

    def test_every_form_of_depth_and_camera_gives_the_same_grasps(self) -> None:
        reference = self.client.grasps(self.depth, intrinsics=INTRINSICS_FILE, strategy="fge")
        with open(INTRINSICS_FILE, "rb") as f:
            intr_bytes = f.read()
        with open(DEPTH_FILE, "rb") as f:
            depth_bytes = f.read()
        variants = {
            "file path, Camera": (DEPTH_FILE, PRIMESENSE),
            "file bytes, .intr bytes": (depth_bytes, intr_bytes),
            "(H, W) float64, .intr as a dict": (self.depth[:, :, 0].astype(np.float64),
                                                json.loads(intr_bytes)),
        }
        for name, (d, camera) in variants.items():
            with self.subTest(name):
                result = self.client.grasps(d, intrinsics=camera, strategy="fge")
                self.assertEqual(result.grasps, reference.grasps)
                self.assertEqual(result.camera.source, "request")

    def test_default_camera_without_intrinsics(self) -> None:
        result = self.client.grasps(self.depth, strategy="fge", top_k=1)
        self.assertEqual(result.camera.source, "default")

    def test_uint16_millimetres(self) -> None:
        millimetres = np.round(np.nan_to_num(self.depth) * 1000).astype(np.uint16)
        result = self.client.grasps(millimetres, intrinsics=INTRINSICS_FILE, strategy="fge")
        self.assertTrue(result.grasps)

    def test_stiffness_under_fge_grasps(self) -> None:
        result = self.client.grasps(self.depth, strategy="fge", mean_stiffness=True, top_k=3)
        self.assertEqual(result.stiffness_model, "pix2stiffness")
        for grasp in result.grasps:
            self.assertTrue(0 <= grasp.mean_stiffness <= 1, grasp.mean_stiffness)

    def test_deformability_strategy_and_its_fields(self) -> None:
        result = self.client.grasps(self.depth, intrinsics=INTRINSICS_FILE,
                                    strategy="deformability", opening_fractions=[0.5, 1],
                                    num_slices=3, target_policy="highest", top_k=5)
        self.assertEqual(result.strategy, "deformability")
        self.assertIsNotNone(result.target)
        self.assertFalse(result.target.fallback)
        self.assertIn(result.target.id, result.target.tried)
        self.assertTrue(result.grasps)
        for grasp in result.grasps:
            self.assertEqual(grasp.instance_id, result.target.id)
            self.assertIn(grasp.deformability.opening_fraction, (0.5, 1.0))
            self.assertLess(grasp.deformability.slice, 3)
            self.assertEqual(grasp.deformability.target_by, "policy")

    def test_gqcnn_strategy(self) -> None:
        result = self.client.grasps(self.depth, intrinsics=INTRINSICS_FILE, strategy="gqcnn",
                                    gqcnn_seed=0, top_k=3)
        self.assertTrue(result.grasps)
        for grasp in result.grasps:
            self.assertEqual(grasp.score, grasp.gqcnn.predicted_quality)
            self.assertIn(grasp.gqcnn.contacts, ("firm", "stable"))
            self.assertAlmostEqual(grasp.gqcnn.grasp_depth_m, grasp.pose.position_m[2])

    def test_segmask_as_file_and_as_array(self) -> None:
        from_file = self.client.grasps(self.depth, strategy="fge", segmask=SEGMASK_FILE)
        self.assertTrue(from_file.segmask)
        self.assertTrue(from_file.grasps)
        nowhere = self.client.grasps(self.depth, strategy="fge",
                                     segmask=np.zeros((480, 640), np.uint8))
        self.assertTrue(nowhere.segmask)
        self.assertEqual(nowhere.grasps, [])

    def test_labels_from_segmentation_and_a_target(self) -> None:
        objects = self.client.segmentation(self.depth, intrinsics=INTRINSICS_FILE)
        target = objects.instances[0].id
        result = self.client.grasps(self.depth, intrinsics=INTRINSICS_FILE, strategy="fge",
                                    labels=objects.labels, target=target)
        self.assertEqual(result.segmentation_source, "labels")
        self.assertEqual(result.segmentation_instances, len(objects.instances))
        self.assertEqual(result.contact_target, target)
        self.assertTrue(result.grasps)
        self.assertEqual({g.instance_id for g in result.grasps}, {target})

    def test_bad_fields_name_the_field(self) -> None:
        self.assertRefused(400, "invalid_argument", "top_k", self.client.grasps, self.depth,
                           top_k=0)
        self.assertRefused(400, "invalid_argument", "strategy", self.client.grasps, self.depth,
                           strategy="bogus")
        self.assertRefused(400, "invalid_argument", "num_slices", self.client.grasps, self.depth,
                           strategy="deformability", num_slices=0)
        self.assertRefused(400, "invalid_argument", "intrinsics", self.client.grasps, self.depth,
                           intrinsics={"focal": 525})

    def test_wrong_depth(self) -> None:
        error = self.assertRefused(400, "invalid_argument", "depth", self.client.grasps,
                                   self.depth * 1000)  # millimetres in a float file
        self.assertIn("1000", error.message)
        self.assertRefused(415, "unsupported_media_type", "depth", self.client.grasps,
                           b"not a depth image")
        self.assertRefused(415, "unsupported_media_type", "depth", self.client.grasps,
                           self.depth.astype(np.float16))

    def test_no_such_target(self) -> None:
        self.assertRefused(422, "unprocessable", "target", self.client.grasps, self.depth,
                           strategy="fge", target=999)
        self.assertRefused(422, "unprocessable", "target_px", self.client.grasps, self.depth,
                           strategy="fge", target_px=(0, 0))

    def test_answer_format_is_the_clients(self) -> None:
        with self.assertRaises(TypeError):
            self.client.grasps(self.depth, format="png")
        with self.assertRaises(ValueError):
            self.client.grasps(self.depth, labels=np.full((480, 640), 70000))


if __name__ == "__main__":
    unittest.main()
