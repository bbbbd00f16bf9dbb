#!/usr/bin/env python3
"""The Python client's tests against real servers (CTest: python_client_test).

1. installs clients/python into a fresh venv of Debian's python3 (--system-site-packages, so
   numpy is Debian's python3-numpy) with the offline command of clients/python/README.md;
2. starts softgrasp-server twice on 127.0.0.1, free ports:
   - with the shipped models and the robot routes off (SOFTGRASP_ROBOT_ENABLED=false);
   - without models, robot routes on with a token, on loopback-only Cyclone DDS with a discovery
     tag of its own, a journal in the work folder;
   and, when softgrasp-sim is built, the simulated robot on that server's bus;
3. runs clients/python/tests (unittest) with the installed package and the servers' URLs in the
   environment (clients/python/tests/support.py), and stops everything.

Fails when a test fails or is skipped; the only skip allowed is the simulated robot's when
softgrasp-sim is not built (a server-only build).

usage: run_client_tests.py --source DIR --server EXE [--sim EXE] [--python PY]
"""
from __future__ import annotations

import argparse
import os
import re
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

START_TIMEOUT_S = 60  # model loading on a busy 2-core machine; the sim builds its scene
TESTS_TIMEOUT_S = 240
DDS_DOMAIN = 134  # this test's own domain; the discovery tag separates parallel runs too
SIM_ROBOT_ID = "sim-python"
NO_SIM_SKIP = "no simulated robot"  # the reason support.py gives

# Runs in the venv: discover the tests, print where softgrasp came from, fail on skips other
# than the allowed ones.
RUN_TESTS = r"""
import sys, unittest, softgrasp
tests, allowed_skip = sys.argv[1], sys.argv[2]
print("softgrasp", softgrasp.__version__, "from", softgrasp.__file__, flush=True)
suite = unittest.defaultTestLoader.discover(tests, top_level_dir=tests)
result = unittest.TextTestRunner(verbosity=2).run(suite)
bad_skips = [(t, why) for t, why in result.skipped
             if not (allowed_skip and why.startswith(allowed_skip))]
for test, why in bad_skips:
    print(f"not allowed to skip: {test}: {why}", file=sys.stderr)
sys.exit(0 if result.wasSuccessful() and not bad_skips else 1)
"""


def loopback_dds_config(tag: str) -> str:
    """Cyclone DDS on 127.0.0.1 only, no multicast, its own discovery tag (as tests/web)."""
    return ("<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface "
            "address=\"127.0.0.1\"/></Interfaces><AllowMulticast>false</AllowMulticast></General>"
            f"<Discovery><Tag>{tag}</Tag><ParticipantIndex>auto</ParticipantIndex>"
            "<MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>"
            "<Peers><Peer address=\"127.0.0.1\"/></Peers><LeaseDuration>2 s</LeaseDuration>"
            "</Discovery></Domain></CycloneDDS>")


class Program:
    """A program that prints "listening on http://HOST:PORT" once it serves."""

    def __init__(self, name: str, argv: list, env: dict) -> None:
        self.name = name
        self.log: list = []
        self.url = None
        self._ready = threading.Event()
        self.process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, env={**os.environ, **env},
                                        text=True, errors="replace")
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.log.append(line)
            match = re.search(r"listening on (http://\S+)", line)
            if match and not self.url:
                self.url = match.group(1)
                self._ready.set()
        self._ready.set()  # exited

    def wait_ready(self) -> str:
        self._ready.wait(START_TIMEOUT_S)
        if not self.url:
            raise RuntimeError(f"{self.name} did not start within {START_TIMEOUT_S} s "
                               f"(exit {self.process.poll()}):\n{self.tail()}")
        return self.url

    def tail(self, lines: int = 40) -> str:
        return "".join(self.log[-lines:])

    def stop(self) -> None:
        """SIGTERM (graceful), SIGKILL after 10 s."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def install_client(python: str, source: str, work: str) -> str:
    """The package installed into a fresh venv; returns the venv's python."""
    # A copy, so that setuptools' build/ and *.egg-info never land in the source tree.
    package = os.path.join(work, "client")
    shutil.copytree(os.path.join(source, "clients", "python"), package,
                    ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    venv = os.path.join(work, "venv")
    subprocess.run([python, "-m", "venv", "--system-site-packages", venv], check=True, timeout=120)
    venv_python = os.path.join(venv, "bin", "python")
    # The offline install of clients/python/README.md.
    subprocess.run([venv_python, "-m", "pip", "install", "--no-build-isolation", "--no-index",
                    "--disable-pip-version-check", "--quiet", package], check=True, timeout=180)
    return venv_python


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--source", required=True, help="the repository")
    parser.add_argument("--server", required=True, help="softgrasp-server")
    parser.add_argument("--sim", help="softgrasp-sim (skipped when the file does not exist)")
    parser.add_argument("--python", default="/usr/bin/python3", help="Debian's python3")
    args = parser.parse_args()

    started = time.monotonic()
    programs: list = []
    with tempfile.TemporaryDirectory(prefix="softgrasp-python-client-") as work:
        try:
            venv_python = install_client(args.python, args.source, work)
            print(f"installed in {time.monotonic() - started:.1f} s", flush=True)

            token = "python-test-" + secrets.token_hex(12)
            dds = loopback_dds_config(f"python-client-{os.getpid()}-{secrets.token_hex(4)}")
            robot_env = {
                "SOFTGRASP_ROBOT_ENABLED": "true", "SOFTGRASP_ROBOT_TOKENS": token,
                "SOFTGRASP_ROBOT_DOMAIN_ID": str(DDS_DOMAIN), "SOFTGRASP_ROBOT_DDS_CONFIG": dds,
                "SOFTGRASP_ROBOT_JOURNAL_DIR": os.path.join(work, "journal"),
                "SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S": "20",
            }
            base = [args.server, "--host", "127.0.0.1", "--port", "0", "--workers", "2"]
            programs.append(Program("server (models)", base,
                                    {"SOFTGRASP_ROBOT_ENABLED": "false"}))
            programs.append(Program("server (robot)", base + [
                "--stiffness-model", "none", "--segmentation-model", "none",
                "--gqcnn-model", "none"], robot_env))
            with_sim = bool(args.sim) and os.path.exists(args.sim)
            if with_sim:
                programs.append(Program("softgrasp-sim robot", [
                    args.sim, "robot", "--scene-seed", "1", "--support", "table",
                    "--robot-id", SIM_ROBOT_ID, "--domain", str(DDS_DOMAIN), "--dds-config", dds,
                    "--http-host", "127.0.0.1", "--http-port", "0"], {}))
            else:
                print(f"softgrasp-sim not built ({args.sim or 'no --sim'}): "
                      "the robot's success path is skipped")
            urls = [p.wait_ready() for p in programs]
            print(f"servers up in {time.monotonic() - started:.1f} s: {' '.join(urls)}", flush=True)

            env = {**os.environ, "SOFTGRASP_URL": urls[0], "SOFTGRASP_ROBOT_URL": urls[1],
                   "SOFTGRASP_ROBOT_TOKEN": token, "SOFTGRASP_SIM_ROBOT_ID": SIM_ROBOT_ID,
                   "SOFTGRASP_TEST_DATA": os.path.join(args.source, "tests", "data"),
                   "PYTHONDONTWRITEBYTECODE": "1"}
            if with_sim:
                env["SOFTGRASP_SIM_URL"] = urls[2]
            tests = os.path.join(args.source, "clients", "python", "tests")
            code = subprocess.run([venv_python, "-c", RUN_TESTS, tests,
                                   "" if with_sim else NO_SIM_SKIP],
                                  env=env, cwd=work, timeout=TESTS_TIMEOUT_S).returncode
            if code != 0:
                for p in programs:
                    print(f"--- {p.name} (last lines) ---\n{p.tail()}", file=sys.stderr)
            return code
        finally:
            for p in programs:
                p.stop()
            print(f"done in {time.monotonic() - started:.1f} s", flush=True)


if __name__ == "__main__":
    sys.exit(main())
