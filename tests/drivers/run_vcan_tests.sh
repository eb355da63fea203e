#!/bin/sh
# Runs the SocketCAN test binary on vcan interfaces, twice: classic (MTU 16) and FD (MTU 72).
#   natively, in a private network namespace, when this kernel can create vcan interfaces;
#   else inside ../shared/tools/run-in-vcan-vm (QEMU, a stock Debian kernel with vcan0..3);
#   else it prints why and exits 77 (ctest: skipped).
# Usage: run_vcan_tests.sh TEST_BINARY [gtest args...]
set -u
bin=$1
shift
here=$(cd "$(dirname "$0")" && pwd)
vm=${HYQ_VCAN_VM:-$here/../../../shared/tools/run-in-vcan-vm}

native_ok() {
  unshare -n sh -c 'ip link add dev hyqprobe type vcan' >/dev/null 2>&1
}

if native_ok; then
  echo "run_vcan_tests: native vcan (kernel $(uname -r)), in a private network namespace"
  rc=0
  for mode in classic fd; do
    mtu=72; [ $mode = classic ] && mtu=16
    unshare -n sh -c '
      for i in 0 1 2 3; do ip link add dev vcan$i type vcan && ip link set vcan$i mtu '$mtu' up || exit 1; done
      HYQ_VCAN_MODE='$mode' exec "$@"' run_vcan "$bin" "$@" || rc=1
  done
  exit $rc
fi

why="this kernel ($(uname -r)) cannot create vcan interfaces"
if [ ! -x "$vm" ]; then
  echo "run_vcan_tests: SKIP: $why, and the VM tool $vm is missing" >&2
  exit 77
fi
if ! command -v qemu-system-x86_64 >/dev/null 2>&1; then
  echo "run_vcan_tests: SKIP: $why, and qemu-system-x86_64 is not installed (scripts/bootstrap.sh)" >&2
  exit 77
fi
echo "run_vcan_tests: $why; running inside $vm"
rc=0
for mode in classic fd; do
  flag=; [ $mode = classic ] && flag=-C
  echo "run_vcan_tests: --- $mode CAN (vcan MTU $([ $mode = classic ] && echo 16 || echo 72)) ---"
  "$vm" -W -n 4 $flag -t 600 -- env HYQ_VCAN_MODE=$mode "$bin" "$@"
  r=$?
  if [ $r -eq 125 ] || [ $r -eq 124 ]; then
    echo "run_vcan_tests: the VM failed to run (exit $r)" >&2
  fi
  [ $r -eq 0 ] || rc=1
done
exit $rc
