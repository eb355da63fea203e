#!/usr/bin/env bash
# Installs the Debian 12 packages this project needs, then hyq-viewer's npm packages (npm ci in
# tools/hyq-viewer/web, pinned by its package-lock.json). Idempotent: when everything is present it
# only runs dpkg-query and compares two timestamps, and exits in well under a second.
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
  # the Debian package (docs/packaging.md): manual pages from --help, dpkg-shlibdeps' file,
  # lintian, and a fresh Debian 12 root booted with systemd for tests/packaging/deb_package_test.sh
  help2man file lintian debootstrap systemd-container
  # hyq-viewer: Boost.Beast (header-only), node to bundle its page, chromium for its browser tests
  # (npm itself: Debian's npm, or the one in a nodesource nodejs)
  libboost-dev nodejs chromium
)

check_only=0
case "${1:-}" in
  --check) check_only=1 ;;
  -h|--help) sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  "") ;;
  *) echo "bootstrap.sh: unknown option '$1' (expected --check or --help)" >&2; exit 2 ;;
esac

missing=()
for p in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

# hyq-viewer's page: npm ci when node_modules is missing or older than package-lock.json
# (npm writes node_modules/.package-lock.json on every install)
npm_packages() {
  local web here
  here="$(cd "$(dirname "$0")/.." && pwd)"
  web="$here/tools/hyq-viewer/web"
  if [[ -d "$web/node_modules" && ! "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]]; then
    echo "bootstrap: hyq-viewer's npm packages present"
    return 0
  fi
  if ((check_only)); then
    echo "bootstrap: hyq-viewer's npm packages missing or stale (npm ci in $web)"
    return 1
  fi
  if ! command -v npm >/dev/null 2>&1; then
    # Debian's nodejs comes without npm (a nodesource nodejs has it): Debian's npm then
    echo "bootstrap: npm not found: installing Debian's npm"
    local sudo=()
    ((EUID != 0)) && sudo=(sudo)
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -q --no-install-recommends npm ||
      { echo "bootstrap: could not install npm: hyq-viewer's page will not be bundled" >&2; return 1; }
  fi
  (cd "$web" && npm ci --no-audit --no-fund)
  echo "bootstrap: installed hyq-viewer's npm packages"
}

if ((${#missing[@]} == 0)); then
  echo "bootstrap: all ${#PACKAGES[@]} packages present"
  npm_packages || exit 1
  exit 0
fi
echo "bootstrap: missing ${#missing[@]} package(s): ${missing[*]}"
((check_only)) && { npm_packages || true; exit 1; }

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
npm_packages
