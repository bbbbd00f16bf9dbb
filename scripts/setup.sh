#!/usr/bin/env bash
# Installs the Debian packages softgrasp needs, only those missing. Idempotent; run as root.
# Never purges or autoremoves: on these images that cascades into libraries we need.
#
# usage: setup.sh            everything: build, tests, benchmarks, container images
#        setup.sh --build    only what compiling softgrasp and its page needs (the build stage
#                            of docker/Dockerfile)
set -euo pipefail

profile=all
case "${1:-}" in
  "") ;;
  --build) profile=build ;;
  *)
    echo "setup: unknown argument '$1' (usage: setup.sh [--build])" >&2
    exit 2
    ;;
esac

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build ccache pkg-config git curl ca-certificates
  # libraries of the service, the simulator and the models
  libopencv-dev libeigen3-dev nlohmann-json3-dev libtiff-dev libpng-dev zlib1g-dev libyaml-cpp-dev
  cyclonedds-dev cyclonedds-tools libembree-dev libpcl-dev libbullet-dev libtorch-dev libcgal-dev
  libqhull-dev libfcl-dev libglpk-dev
  # an optimised BLAS for libtorch's fully connected layers: without it Debian's alternatives
  # give the reference libblas3, and the GQ-CNN's plans take 1.6x as long (docs/gqcnn.md)
  libopenblas0-openmp
)
if [ "$profile" = all ]; then
  PACKAGES+=(
    # clang: the fuzz targets and the formatting check
    clang clang-format libclang-rt-14-dev
    # tests and benchmarks; chromium drives the browser tests of the web page (tests/web)
    libgtest-dev libgmock-dev libbenchmark-dev chromium
    # the two-host test (tests/netns): network namespaces and veth pairs, HTTP and JSON in bash
    iproute2 jq
    # the layering test (tests/layout_test.py)
    python3
    # the Python client's test (tests/python): numpy, and a venv with pip and setuptools to install
    # clients/python offline
    python3-numpy python3-venv python3-pip python3-setuptools
    # the HTTP benchmark (scripts/bench-http.sh): nginx as the baseline, wrk as the load
    nginx-light wrk
    # container images (scripts/images.sh: a Debian base by debootstrap, images by buildah) and
    # their tests (tests/containers: HAProxy balances the service replicas)
    buildah debootstrap haproxy
    # datasets on Slurm (tests/slurm starts a one-node cluster; scripts/slurm-batch.sh)
    slurmctld slurmd slurm-client munge
  )
fi
# node and npm bundle the web page (scripts/build.sh). Any node >= 18 will do: Debian's nodejs and
# npm are added only when no node is on the PATH, so a newer one already installed is kept.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  PACKAGES+=(nodejs npm)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "setup: missing packages: ${missing[*]}; run as root to install them" >&2
  exit 1
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
# Packages with a daemon (nginx, haproxy) must not start it: a policy that refuses service starts, kept
# only for this install when the machine has none of its own.
policy=/usr/sbin/policy-rc.d
own_policy=0
if [ ! -e "$policy" ]; then
  printf '#!/bin/sh\nexit 101\n' >"$policy"
  chmod +x "$policy"
  own_policy=1
fi
trap '[ "$own_policy" = 1 ] && rm -f "$policy"' EXIT
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
