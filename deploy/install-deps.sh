#!/usr/bin/env bash
# Installs the Debian packages coins needs to build, test and run. Idempotent: when every
# package is already installed it only checks and returns in about a second.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # middleware and code generation
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  # numerics, physics, sparse least squares
  libeigen3-dev libmujoco-dev libqhull-dev libsuitesparse-dev
  # offscreen rendering through EGL (software Mesa) and image encoders
  libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri libpng-dev libgif-dev
  # config, CLI, logging, JSON
  libyaml-cpp-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev
  # tests and benchmarks; the test command's format check (deploy/format.sh)
  libgtest-dev libgmock-dev libbenchmark-dev clang-format-14
  # learning-curve PNGs of `coins run` (gnuplot without X11)
  gnuplot-nox
  # the cluster test's network namespaces (ip netns), the DDS Security certificates and their checks
  iproute2 openssl libssl-dev
  # the Slurm test (tests/slurm_test.sh): a private Slurm cluster on this machine
  slurm-wlm munge
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages (${missing[*]}); run as root or install them with apt-get" >&2
  exit 1
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
