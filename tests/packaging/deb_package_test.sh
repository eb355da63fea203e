#!/usr/bin/env bash
# The Debian package in a fresh Debian 12 root (docs/packaging.md):
#   1. debootstrap a minimal bookworm with systemd; its dependencies from Debian's mirror (apt);
#   2. boot it (systemd-nspawn -b, private network: loopback only) and, inside, under systemd:
#      install the package; the service user and a key readable by it alone; the unit installed,
#      neither enabled nor started; start hyq-sim on the virtual CAN buses and the unit against it
#      (the sim configuration, the command channel open with the package's key); wait for ACTIVE,
#      trot, `systemctl stop` = a controlled stop; upgrade to a newer version (a local edit to a
#      conffile and the key survive); enable the unit; purge;
#   3. the root after the purge has the same files as before the install.
# usage: deb_package_test.sh DEB WORK_DIR
# Exit 77 (skipped, with the reason) without root, debootstrap, systemd-nspawn or the mirror.
set -euo pipefail

deb=$(readlink -f "${1:?usage: deb_package_test.sh DEB WORK_DIR}")
work=${2:?usage: deb_package_test.sh DEB WORK_DIR}
mirror=${HYQ_DEBIAN_MIRROR:-http://deb.debian.org/debian}
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*" >&2; exit 1; }

((EUID == 0)) || skip "needs root (debootstrap, systemd-nspawn)"
command -v debootstrap >/dev/null || skip "debootstrap not installed (scripts/bootstrap.sh installs it)"
command -v systemd-nspawn >/dev/null ||
  skip "systemd-nspawn not installed (systemd-container; scripts/bootstrap.sh installs it)"
[[ -f "$deb" ]] || fail "no package at $deb (cmake --build --preset ci --target package makes it)"
host=${mirror#*://}
host=${host%%/*}
timeout 10 bash -c "exec 3<>/dev/tcp/$host/80" 2>/dev/null || skip "the Debian mirror $mirror is unreachable"

mkdir -p "$work"
work=$(readlink -f "$work")
# the network steps get three tries: a mirror's passing hiccup is not the package's failure
retry3() { "$@" || { sleep 5; "$@"; } || { sleep 15; "$@"; }; }
root="$work/root"
results="$work/results"
debs="$work/debs"
umask 022
rm -rf "$root" "$results" "$debs"
mkdir -p "$results" "$debs"

# the packages: the one built, and a newer version of it for the upgrade (the same files under
# version <v>+upgrade1: what an upgrade does with conffiles, the key and a running unit)
version=$(dpkg-deb -f "$deb" Version)
cp "$deb" "$debs/old.deb"
dpkg-deb -R "$deb" "$work/repack"
sed -i "s/^Version: .*/Version: ${version}+upgrade1/" "$work/repack/DEBIAN/control"
dpkg-deb --root-owner-group -b "$work/repack" "$debs/new.deb" >/dev/null
rm -rf "$work/repack"

# a fresh Debian 12 root; the minbase tarball is kept for a day to spare the mirror on reruns
base="$work/bookworm-minbase.tar"
if [[ ! -f "$base" || -n $(find "$base" -mmin +1440) ]]; then
  echo "deb_package_test: debootstrap bookworm from $mirror"
  retry3 debootstrap --variant=minbase --include=systemd,systemd-sysv,dbus,iproute2 \
    --make-tarball="$base.new" bookworm "$work/tarball-tmp" "$mirror" >"$work/debootstrap.log" 2>&1 ||
    fail "debootstrap --make-tarball failed three times (see $work/debootstrap.log)"
  mv "$base.new" "$base"
  rm -rf "$work/tarball-tmp"
fi
debootstrap --variant=minbase --include=systemd,systemd-sysv,dbus,iproute2 \
  --unpack-tarball="$base" bookworm "$root" "$mirror" >>"$work/debootstrap.log" 2>&1 ||
  fail "debootstrap failed (see $work/debootstrap.log)"
echo "deb_package_test: Debian 12 root in $root"

nspawn=(systemd-nspawn -q -D "$root" --register=no --keep-unit)
# the package's dependencies from Debian (this is the only step that needs the network)
depends=$(dpkg-deb -f "$deb" Depends)
retry3 "${nspawn[@]}" env DEBIAN_FRONTEND=noninteractive sh -c \
  "apt-get -q update && apt-get -q -y --no-install-recommends satisfy '$depends'" \
  >"$work/apt.log" 2>&1 || fail "installing the dependencies ($depends) failed three times (see $work/apt.log)"
echo "deb_package_test: dependencies installed"

# the driver runs inside the booted root as a unit of its own, then powers it off
mkdir -p "$root/debs" "$root/results"
install -m 0755 "$(dirname "$0")/deb_package_driver.sh" "$root/usr/local/sbin/hyq-package-check"
cat >"$root/etc/systemd/system/hyq-package-check.service" <<'EOF'
[Unit]
Description=hyq-servo package check (tests/packaging/deb_package_test.sh)
After=multi-user.target
[Service]
Type=oneshot
ExecStart=/usr/local/sbin/hyq-package-check
ExecStopPost=/bin/systemctl poweroff --no-block
StandardOutput=append:/results/driver.log
StandardError=append:/results/driver.log
EOF
boot() {  # boot the root; the driver's phase in /results/phase
  echo "$1" >"$results/phase"
  ln -sf /etc/systemd/system/hyq-package-check.service \
    "$root/etc/systemd/system/multi-user.target.wants/hyq-package-check.service"
  timeout 600 "${nspawn[@]}" -b --private-network --capability=CAP_IPC_LOCK,CAP_SYS_NICE \
    --bind-ro="$debs:/debs" --bind="$results:/results" >"$work/boot-$1.log" 2>&1 ||
    fail "booting the root for '$1' failed or timed out (see $work/boot-$1.log)"
  rm -f "$root/etc/systemd/system/multi-user.target.wants/hyq-package-check.service"
}

# what the root holds: every path with its type, mode, owner and size, and the accounts' files'
# checksums; without what a boot or apt changes by itself (logs, caches, journals, dpkg's and
# apt's records, systemd's state, the random seed)
snapshot() {
  (cd "$root" && find . -xdev \( -path ./proc -o -path ./sys -o -path ./dev -o -path ./run -o \
    -path ./tmp -o -path ./var/tmp -o -path ./var/log -o -path ./var/cache -o -path ./var/lib/apt -o \
    -path ./var/lib/dpkg -o -path ./var/lib/systemd -o -path ./results -o -path ./debs \) -prune -o \
    \( -name '*-' -path './etc/*' \) -prune -o -printf '%p %y %m %u %g %s\n' | LC_ALL=C sort
   md5sum etc/passwd etc/group etc/shadow etc/gshadow)
}

boot baseline  # the first boot's own files (machine-id, ...) are in the snapshot before
snapshot >"$work/before.txt"
boot check
cat "$results/driver.log" 2>/dev/null || true
grep -q '^PASS$' "$results/verdict" 2>/dev/null ||
  fail "the check inside the root failed: $(grep -m1 '^FAIL' "$results/verdict" 2>/dev/null || echo 'no verdict')"

# the run under systemd: a controlled stop from ACTIVE, the robot on its feet while ACTIVE
/usr/bin/python3 - "$results" <<'PY' || fail "the daemon's run under the unit"
import json, os, sys
r = sys.argv[1]
s = json.load(open(os.path.join(r, "servod.json")))
sim = json.load(open(os.path.join(r, "sim1.json")))
print(f"deb_package_test: unit run: {s['active_s']:.2f} s ACTIVE, final mode {s['final_mode']}, "
      f"events {s['events'] or 'none'}; sim fell {sim.get('fell')}, sat down {sim.get('sat_down')}")
assert s["active_s"] > 3.0, "expected over 3 s ACTIVE"
assert s["final_mode"] == "stopped", f"expected the final mode stopped, found {s['final_mode']}"
assert s["events"].get("stop_request", 0) >= 1, "expected the stop request (SIGTERM) among the events"
bad = {k: v for k, v in s["events"].items()
       if k not in ("bring_up_complete", "enable_command", "stop_request", "damping_done")}
assert not bad, f"unexpected events {bad}"
t_stop = sim.get("released_at_s", 0.0) + s["active_s"]
contact = sim["fell_at_s"] if sim.get("fell") else sim["sat_down_at_s"] if sim.get("sat_down") else None
assert contact is None or contact >= t_stop - 1e-9, f"the trunk touched at {contact} s while ACTIVE"
PY

snapshot >"$work/after.txt"
if ! diff -u "$work/before.txt" "$work/after.txt" >"$work/leftovers.diff"; then
  cat "$work/leftovers.diff"
  fail "the purge left the root different from before the install (above)"
fi
echo "deb_package_test: the purge left the root as it was ($(wc -l <"$work/before.txt") paths compared)"
echo "deb_package_test: PASS"
