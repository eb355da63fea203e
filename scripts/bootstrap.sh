#!/usr/bin/env bash
# Installs the Debian 12 packages this project needs. Idempotent: when everything is present it
# only runs dpkg-query and exits in well under a second.
#
#   scripts/bootstrap.sh            install what is missing
#   scripts/bootstrap.sh --check    list what is missing, install nothing (exit 1 if anything is)
set -euo pipefail

readonly PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config clang libclang-rt-14-dev
  # libraries
  libeigen3-dev liburdfdom-dev liburdfdom-headers-dev libtinyxml2-dev libyaml-cpp-dev nlohmann-json3-dev libssl-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libmujoco-dev libgl-dev libqhull-dev
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev default-jdk-headless libjchart2d-java
  default-jre   # lcm-spy is a Swing window: the AWT/X11 half of the JRE (not in -headless)
  # CAN and test references
  can-utils iproute2 python3 python3-can python3-cvxopt python3-numpy python3-matplotlib
  libdart-utils-urdf-dev   # DART 6.12: the dynamics reference of tests/dynamics/dart_benchmark
  rt-tests xvfb x11-apps imagemagick util-linux
  tmux   # drives hyq-teleop in tests/tools/teleop_test.sh
  # run-in-vcan-vm (../shared/tools): a stock Debian kernel with vcan under QEMU
  qemu-system-x86 busybox-static kmod
  # msgpack for python-can's udp_multicast interface, libFuzzer via clang
  python3-msgpack
)

check_only=0
case "${1:-}" in
  --check) check_only=1 ;;
  -h|--help) sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  "") ;;
  *) echo "bootstrap.sh: unknown option '$1' (expected --check or --help)" >&2; exit 2 ;;
esac

missing=()
for p in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "bootstrap: all ${#PACKAGES[@]} packages present"
  exit 0
fi
echo "bootstrap: missing ${#missing[@]} package(s): ${missing[*]}"
((check_only)) && exit 1

sudo_cmd=()
if ((EUID != 0)); then
  if command -v sudo >/dev/null 2>&1; then
    sudo_cmd=(sudo)
  else
    echo "bootstrap: need root to install packages, and sudo is not installed." >&2
    echo "           run as root: apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi

export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "bootstrap: installed ${#missing[@]} package(s)"
