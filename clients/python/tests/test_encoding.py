"""What the client sends and reads, without a server: form values, multipart, PNG, answers."""
from __future__ import annotations

import io
import struct
import unittest
import zlib

import numpy as np

import softgrasp
from softgrasp import _http, _inputs, _png


class FormValuesTest(unittest.TestCase):
    def test_values(self) -> None:
        self.assertEqual(_http.form_value(True), "true")
        self.assertEqual(_http.form_value(np.bool_(False)), "false")
        self.assertEqual(_http.form_value(5), "5")
        self.assertEqual(_http.form_value(np.float32(0.5)), "0.5")
        self.assertEqual(_http.form_value([0.5, 0.75, 1]), "0.5,0.75,1")
        self.assertEqual(_http.form_value((320, 240)), "320,240")
        self.assertEqual(_http.form_value(np.array([1, 2])), "1,2")
        self.assertEqual(_http.form_fields({"a": None, "b": 1}), {"b": "1"})
        with self.assertRaises(TypeError):
            _http.form_value(object())

    def test_multipart(self) -> None:
        depth = _http.Part("depth", b"\x00\x01", "d.npy")
        body, content_type = _http.multipart({"top_k": "3"}, [depth])
        boundary = content_type.split("boundary=")[1].encode()
        self.assertTrue(body.startswith(b"--" + boundary + b"\r\n"))
        self.assertTrue(body.endswith(b"--" + boundary + b"--\r\n"))
        self.assertIn(b'name="top_k"\r\n\r\n3\r\n', body)
        self.assertIn(b'name="depth"; filename="d.npy"\r\nContent-Type: application/octet-stream'
                      b'\r\n\r\n\x00\x01\r\n', body)

    def test_depth_array_is_npy(self) -> None:
        depth = np.arange(12, dtype=np.float32).reshape(3, 4)
        part = _inputs.depth_part(depth)
        np.testing.assert_array_equal(np.load(io.BytesIO(part.data)), depth)

    def test_camera_goes_as_fields(self) -> None:
        fields, parts = _inputs.intrinsics_parts(softgrasp.Camera(525, 526, 319.5, 239.5, 640, 480))
        self.assertEqual(fields, {"fx": "525", "fy": "526", "cx": "319.5", "cy": "239.5"})
        self.assertEqual(parts, [])


def png_with_filter(image: np.ndarray, kind: int) -> bytes:
    """An 8-bit grey PNG whose every row uses filter ``kind`` (as an encoder may choose)."""
    height, width = image.shape
    raw = bytearray()
    prior = [0] * width
    for row in image.astype(int).tolist():
        out = []
        for i, x in enumerate(row):
            left = row[i - 1] if i else 0
            up, upper_left = prior[i], (prior[i - 1] if i else 0)
            if kind == 1:
                predictor = left
            elif kind == 2:
                predictor = up
            elif kind == 3:
                predictor = (left + up) // 2
            else:
                p = left + up - upper_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - upper_left)
                predictor = left if pa <= pb and pa <= pc else up if pb <= pc else upper_left
            out.append((x - predictor) & 0xFF)
        raw += bytes([kind] + out)
        prior = row

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(bytes(raw))) + chunk(b"IEND", b""))


class PngTest(unittest.TestCase):
    def test_round_trip(self) -> None:
        rng = np.random.default_rng(1)
        for dtype in (np.uint8, np.uint16):
            image = rng.integers(0, np.iinfo(dtype).max, (7, 5), endpoint=True).astype(dtype)
            decoded = _png.decode_grey(_png.encode_grey(image))
            self.assertEqual(decoded.dtype, dtype)
            np.testing.assert_array_equal(decoded, image)

    def test_every_row_filter(self) -> None:
        image = np.random.default_rng(2).integers(0, 256, (6, 9)).astype(np.uint8)
        for kind in (1, 2, 3, 4):
            with self.subTest(filter=kind):
                np.testing.assert_array_equal(_png.decode_grey(png_with_filter(image, kind)), image)

    def test_refuses_what_it_does_not_read(self) -> None:
        with self.assertRaises(ValueError):
            _png.decode_grey(b"GIF89a")
        with self.assertRaises(ValueError):
            _png.encode_grey(np.zeros((2, 2), np.float32))


class AnswersTest(unittest.TestCase):
    def test_error_body(self) -> None:
        body = (b'{"error": {"code": "invalid_argument", "message": "top_k must be ...", '
                b'"field": "top_k"}}')
        error = softgrasp.SoftgraspError.from_answer(400, {}, body)
        self.assertEqual((error.status, error.code, error.field),
                         (400, "invalid_argument", "top_k"))
        self.assertEqual(str(error), "400 invalid_argument (field top_k): top_k must be ...")
        other = softgrasp.SoftgraspError.from_answer(502, {"Retry-After": "5"},
                                                     b"<html>bad gateway")
        self.assertEqual((other.code, other.message, other.retry_after),
                         ("http_error", "<html>bad gateway", 5))

    def test_robot_command_with_a_result(self) -> None:
        # A finished command as GET /v1/robot/grasps/{id} answers it (openapi.yaml RobotCommand).
        answer = {
            "id": "pick-1", "state": "succeeded", "robot_id": "sim-robot", "object_id": "",
            "accepted_unix_s": 1700000000.5,
            "command": {"id": "pick-1", "robot_id": "sim-robot", "object_id": "",
                        "frame_id": "camera", "position_m": [0.01, -0.02, 0.65],
                        "orientation_wxyz": [1, 0, 0, 0], "opening_m": 0.05, "force_n": 10,
                        "approach_m": 0.1, "retreat_m": 0.1, "score": 0.8},
            "result": {"command_id": "pick-1", "robot_id": "sim-robot", "object_id": "",
                       "outcome": "succeeded", "reason": "held object 2", "contact_width_m": 0.0434,
                       "grasped_width_m": 0.0432, "deformation_rate": 0.004, "execution_s": 0.02,
                       "finished_unix_ns": 1700000001000000000, "finished_unix_s": 1700000001.0,
                       "received_unix_s": 1700000001.1, "round_trip_s": 0.6, "late": False},
        }
        command = softgrasp.RobotCommand.from_json(answer, 200)
        self.assertTrue(command.finished)
        self.assertEqual(command.command.position_m, (0.01, -0.02, 0.65))
        self.assertEqual(command.result.finished_unix_ns, 1700000001000000000)
        self.assertIsNone(command.detail)


if __name__ == "__main__":
    unittest.main()
