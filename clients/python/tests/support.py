"""What the tests share: the servers under test (from the environment) and the real frames.

tests/python/run_client_tests.py starts the servers and sets:
  SOFTGRASP_URL           a server with the shipped models and the robot routes turned off
  SOFTGRASP_ROBOT_URL     a server without models, robot routes on, SOFTGRASP_ROBOT_TOKEN its token
  SOFTGRASP_SIM_URL       the simulated robot's views (its camera), when softgrasp-sim is built;
                          that robot is on the robot server's DDS bus
  SOFTGRASP_TEST_DATA     the repository's tests/data
Tests whose server is not given are skipped.
"""
from __future__ import annotations

import os
import unittest
from typing import Any, Callable

import numpy as np

import softgrasp

URL = os.environ.get("SOFTGRASP_URL")
ROBOT_URL = os.environ.get("SOFTGRASP_ROBOT_URL")
ROBOT_TOKEN = os.environ.get("SOFTGRASP_ROBOT_TOKEN")
SIM_URL = os.environ.get("SOFTGRASP_SIM_URL")
DATA = os.environ.get("SOFTGRASP_TEST_DATA") or os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "tests", "data")

PRIMESENSE = os.path.join(DATA, "gqcnn", "primesense")
DEPTH_FILE = os.path.join(PRIMESENSE, "single_depth_0.npy")  # 640 x 480, float32 metres
INTRINSICS_FILE = os.path.join(PRIMESENSE, "primesense.intr")  # GQ-CNN .intr: fx = fy = 525
SEGMASK_FILE = os.path.join(PRIMESENSE, "single_segmask_0.png")  # 8-bit grey, the object
MESH_FILE = os.path.join(DATA, "meshes", "dexnet_bar_clamp.obj")

TIMEOUT_S = 60.0  # per request; the whole run has CTest's timeout


def client() -> softgrasp.Client:
    """The server with models, robot routes off."""
    if not URL:
        raise unittest.SkipTest("no server: set SOFTGRASP_URL "
                                "(tests/python/run_client_tests.py does)")
    return softgrasp.Client(URL, timeout=TIMEOUT_S)


def robot_client(token: Any = ROBOT_TOKEN) -> softgrasp.Client:
    """The server with robot routes on and no models, with ``token`` (None: no token)."""
    if not ROBOT_URL:
        raise unittest.SkipTest("no robot server: set SOFTGRASP_ROBOT_URL and "
                                "SOFTGRASP_ROBOT_TOKEN")
    return softgrasp.Client(ROBOT_URL, timeout=TIMEOUT_S, robot_token=token)


def depth() -> np.ndarray:
    """Primesense frame 0, metres, shape (480, 640, 1)."""
    return np.load(DEPTH_FILE)


class ServerTest(unittest.TestCase):
    def assertRefused(self, status: int, code: str, field: Any, call: Callable[..., Any],
                      *args: Any, **kwargs: Any) -> softgrasp.SoftgraspError:
        """``call`` raises SoftgraspError with this status, code and field, and a message."""
        with self.assertRaises(softgrasp.SoftgraspError) as caught:
            call(*args, **kwargs)
        error = caught.exception
        self.assertEqual((error.status, error.code, error.field), (status, code, field), str(error))
        self.assertTrue(error.message)
        return error
