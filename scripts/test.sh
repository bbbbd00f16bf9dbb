#!/usr/bin/env bash
# Installs what is missing, checks the C++ formatting (clang-format), builds, builds the container
# images, and runs the whole test suite (unit, integration, contract, fuzz-corpus replay, the page
# in headless chromium, the images as hosts in network namespaces), then an ASan+UBSan build of
# the HTTP and codec tests and a ThreadSanitizer build of the server and robot-command tests.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/setup.sh"
bash "$root/scripts/check-format.sh"
bash "$root/scripts/build.sh"
# The container images (docker/Dockerfile: service, robot, worker) for the container tests (label
# "containers"): buildah on a Debian base made here by debootstrap, the host's ccache mounted, so
# this takes minutes only when the sources changed (docs/containers.md). Needs root.
# SOFTGRASP_CONTAINERS_SKIP=1 skips the images and those tests.
if [ "${SOFTGRASP_CONTAINERS_SKIP:-0}" != 1 ]; then
  bash "$root/scripts/images.sh"
fi
ctest --test-dir "${SOFTGRASP_BUILD_DIR:-$root/build}" -j "$(nproc)" --output-on-failure

# The code that reads bytes from outside (HTTP parsing, static files, image and mesh decoders, the
# preparation of uploaded meshes, the JSON codec), once more under AddressSanitizer + UBSan: their
# unit tests and the fuzz-corpus replays; the grasp planners (the fast FGE's buffer and index
# arithmetic); the mesh grasp analysis (Qhull's C memory, Embree and FCL queries); and the GQ-CNN
# crop (raw pixel indexing of a rotated window).
SOFTGRASP_BUILD_DIR="$root/build-asan" SOFTGRASP_WEB=0 \
SOFTGRASP_TARGETS="http_message_test http_parser_test http_response_writer_test
  http_router_test http_server_test
  http_static_files_test io_npy_test io_png_tiff_test io_mask_test io_intrinsics_test
  io_fuzz_corpus_test mesh_io_test mesh_prepare_test http_request_replay depth_decode_replay
  mask_decode_replay mesh_decode_replay response_writer_replay codec_test json_codec_replay
  preprocess_test fge_test fge_stiffness_test
  raycast_test mesh_stable_poses_test mesh_grasp_quality_test mesh_antipodal_test
  mesh_gripper_collision_test mesh_grasp_analysis_test gqcnn_dataset_format_test gqcnn_shard_replay
  gqcnn_crop_test" \
  bash "$root/scripts/build.sh" -DSOFTGRASP_SANITIZER=address,undefined -DSOFTGRASP_BUILD_BENCHMARKS=OFF
# Tests of targets not built in this pass show up as *_NOT_BUILT: skip them.
ctest --test-dir "$root/build-asan" -j "$(nproc)" --output-on-failure -L 'http|io|mesh|fuzz|core|gqcnn' \
  -E 'NOT_BUILT'

# The threaded parts once more under ThreadSanitizer: the HTTP server (I/O thread, workers,
# hand-backs), static files, and the robot command record (tracker thread, journal, DDS).
SOFTGRASP_BUILD_DIR="$root/build-tsan" SOFTGRASP_WEB=0 \
SOFTGRASP_TARGETS="http_server_test http_static_files_test robot_journal_test
  robot_command_tracker_test" \
  bash "$root/scripts/build.sh" -DSOFTGRASP_SANITIZER=thread -DSOFTGRASP_BUILD_BENCHMARKS=OFF
TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$root/tests/tsan.supp" \
  ctest --test-dir "$root/build-tsan" -j "$(nproc)" --output-on-failure -L 'http|robot' \
  -E 'NOT_BUILT'
