#!/usr/bin/env bash
# Installs the Debian 12 packages that cpmesh needs to build, run and test. Non-interactive and idempotent: when every
# package is already installed it changes nothing (not even the package lists).
set -euo pipefail

packages=(
  cmake ninja-build g++ pkg-config     # build
  libvulkan-dev                        # Vulkan loader and headers (Vulkan-Hpp included)
  mesa-vulkan-drivers                  # lavapipe: the CPU Vulkan driver, for machines without a GPU and for CI
  glslang-tools                        # glslangValidator: GLSL compute shaders to SPIR-V at build time
  vulkan-validationlayers              # the tests run with validation on
  libglm-dev libtet1.5-dev zlib1g-dev  # vector maths, TetGen, gzip
  libcli11-dev                         # command-line parsing: subcommands, validation and --help for free
  libtbb-dev                           # oneTBB: parallel loops over voxels and lines for the fields (work stealing)
  nlohmann-json3-dev                   # report.json and benchmark JSON lines
  doctest-dev                          # tests
  python3 python3-numpy                # cpmesh-check: the independent checker of written meshes (vectorised geometry)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages are installed"
  exit 0
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
