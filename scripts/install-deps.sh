#!/usr/bin/env bash
# The one list of CDFF's system dependencies: Debian 12 packages only.
# Idempotent: returns quickly when everything is already installed.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build ccache lld pkg-config git clang-format
  # core libraries
  libeigen3-dev libopencv-dev libopencv-contrib-dev libpcl-dev libceres-dev libvisp-dev
  liboctomap-dev liburdfdom-dev liborocos-kdl-dev libtinyxml-dev libconsole-bridge-dev
  libembree-dev libegl-dev libgl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  libzstd-dev liblz4-dev zlib1g-dev libboost-dev
  # DDS transport (Eclipse Cyclone DDS; its IDL compiler idlc and ddsperf are in -tools)
  cyclonedds-dev cyclonedds-tools
  # ESROCOS ASN.1 types: uPER codecs generated at build time (asn1c's skeletons are in the package)
  asn1c
  # real data to validate on (ViSP tracking sequences with ground truth)
  visp-images-data
  # tests, benchmarks, bindings
  libgtest-dev libgmock-dev libbenchmark-dev pybind11-dev python3-dev python3-yaml
  python3-numpy python3-pytest python3-matplotlib
  # verification campaigns on a cluster (the tests start a private single-node Slurm)
  slurm-wlm munge
  # peers measured in the benchmarks (Open3D: global registration)
  libopen3d-dev
  # the web UI's browser tests (`cdff serve`, docs/web-ui.md): Playwright drives this Chromium
  # headless; the HTTP/WebSocket server is Boost.Beast, header-only in libboost-dev above
  chromium
)

# Only for `make fuzz` (scripts/install-deps.sh fuzz): clang with libFuzzer and its sanitizers.
if [ "${1:-}" = "fuzz" ]; then
  packages+=(clang libclang-rt-14-dev)
fi

missing=()
# The web UI (web/) is bundled with esbuild from npm at build time, and the MCAP
# interoperability test runs the official TypeScript MCAP reader under Node.js: install Debian's
# nodejs and npm only when no node is on the PATH (a newer one may be installed).
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  missing+=(nodejs npm)
fi
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages: ${missing[*]}" >&2
  echo "install-deps: run as root (or: sudo $0) to install them" >&2
  exit 1
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
