"""Client.segmentation against the real server: POST /v1/segmentation."""
from __future__ import annotations

import unittest

import numpy as np

from support import INTRINSICS_FILE, ServerTest, client, depth, robot_client


class SegmentationTest(ServerTest):
    def setUp(self) -> None:
        self.client = client()
        self.depth = depth()

    def test_instances_and_their_label_image(self) -> None:
        objects = self.client.segmentation(self.depth, intrinsics=INTRINSICS_FILE)
        self.assertEqual(objects.method, "model")
        self.assertEqual(objects.segmentation_model, "segmentation")
        self.assertEqual(objects.camera.source, "request")
        self.assertTrue(objects.instances)
        ids = [i.id for i in objects.instances]
        self.assertEqual(ids, list(range(1, len(ids) + 1)))
        labels = objects.labels
        self.assertEqual((labels.dtype, labels.shape), (np.uint16, (480, 640)))
        self.assertEqual(set(np.unique(labels)) - {0}, {i.id for i in objects.instances})
        for instance in objects.instances:
            with self.subTest(instance=instance.id):
                rows, cols = np.nonzero(labels == instance.id)
                self.assertEqual(instance.area_px, rows.size)
                self.assertEqual(instance.bbox_px, (cols.min(), rows.min(),
                                                    cols.max() - cols.min() + 1,
                                                    rows.max() - rows.min() + 1))
                self.assertAlmostEqual(instance.centroid_px[0], cols.mean(), places=6)
                self.assertAlmostEqual(instance.centroid_px[1], rows.mean(), places=6)
                self.assertTrue(0 <= instance.score <= 1)
                self.assertTrue(0 <= instance.mean_deformability <= 1)
                self.assertTrue(0 <= instance.mean_stiffness <= 1)
                self.assertTrue(0.4 < instance.centroid_m[2] < 0.8)  # camera frame, metres

    def test_pcl_baseline_without_labels(self) -> None:
        objects = self.client.segmentation(self.depth, method="pcl", labels=False)
        self.assertEqual(objects.method, "pcl")
        self.assertIsNone(objects.labels)
        self.assertTrue(objects.instances)
        for instance in objects.instances:
            self.assertIsNone(instance.mean_deformability)  # PCL estimates none

    def test_refusals(self) -> None:
        self.assertRefused(400, "invalid_argument", "method", self.client.segmentation,
                           self.depth, method="bogus")
        self.assertRefused(415, "unsupported_media_type", "depth", self.client.segmentation,
                           b"\x00" * 64)
        error = self.assertRefused(503, "service_unavailable", "method",
                                   robot_client().segmentation, self.depth, method="model")
        self.assertIn("segmentation model", error.message)
        with self.assertRaises(TypeError):
            self.client.segmentation(self.depth, format="overlay")


if __name__ == "__main__":
    unittest.main()
