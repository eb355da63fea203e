#!/usr/bin/env bash
# What a new user sees: makes a minimal Debian 12 root (debootstrap --variant=minbase bookworm,
# plus git and ca-certificates to clone), clones this checkout into it, puts a read-only copy of
# ../shared beside it, runs the README's two commands inside (scripts/run.sh, then
# scripts/test.sh, with CI=true and no stdin, as CI does) and prints their exit codes, times and
# the last lines of each. Not part of the test suite (about an hour on 2 cores); run it before
# changing what the two commands install or build.
#
#   scripts/fresh_machine_check.sh [--root DIR] [--keep] [--mirror URL]
#
# Needs root (debootstrap, chroot, mounts) and network access to the Debian mirror; installs
# debootstrap on this machine if it is missing. --keep leaves the root (default: removed).
# Output: DIR.log (everything) and the summary on stdout. Exit status 0 when both commands pass.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
root=/var/tmp/hyq-fresh-root keep=0 mirror=http://deb.debian.org/debian
while (($#)); do
  case "$1" in
    --root) root="$2"; shift ;;
    --keep) keep=1 ;;
    --mirror) mirror="$2"; shift ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "fresh_machine_check: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
((EUID == 0)) || { echo "fresh_machine_check: needs root (debootstrap, chroot)" >&2; exit 2; }
[[ -d "$here/../shared" ]] || { echo "fresh_machine_check: no ../shared beside $here" >&2; exit 2; }
log="$root.log"
: > "$log"
step() { printf '[%s] %s\n' "$(date +%T)" "$*" | tee -a "$log"; }

if ! command -v debootstrap >/dev/null; then
  step "installing debootstrap on this machine"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >>"$log" 2>&1
fi
cleanup() {
  for m in "$root/work/shared" "$root/dev/pts" "$root/dev" "$root/sys" "$root/proc"; do
    mountpoint -q "$m" 2>/dev/null && umount -l "$m"
  done
  ((keep)) || rm -rf "$root"
}
trap cleanup EXIT
rm -rf "$root"
step "debootstrap --variant=minbase bookworm $root ($mirror)"
t0=$SECONDS
debootstrap --variant=minbase --include=git,ca-certificates bookworm "$root" "$mirror" >>"$log" 2>&1
step "root made in $((SECONDS - t0)) s ($(du -sh "$root" | cut -f1))"

# the checkout as committed (a clone: nothing untracked, no build trees) and ../shared read-only
mkdir -p "$root/work/shared"
git clone -q "$here" "$root/work/main"
mount --bind "$here/../shared" "$root/work/shared"
mount -o remount,bind,ro "$root/work/shared"
mount -t proc proc "$root/proc"
mount --rbind /sys "$root/sys"
mount --rbind /dev "$root/dev"
cp /etc/resolv.conf "$root/etc/resolv.conf"
# this host's own certificate authorities (where a TLS-inspecting proxy stands in front of the
# package registries, as on this project's machines): the root trusts what the host trusts, and
# node (npm) reads the system store through NODE_EXTRA_CA_CERTS as the host's does. A machine
# without them (a plain Debian 12) needs neither.
extra_ca=()
if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
  mkdir -p "$root/usr/local/share/ca-certificates"
  cp /usr/local/share/ca-certificates/*.crt "$root/usr/local/share/ca-certificates/"
  chroot "$root" update-ca-certificates >>"$log" 2>&1
  extra_ca=(NODE_EXTRA_CA_CERTS=/etc/ssl/certs/ca-certificates.crt)
  step "the host's extra certificate authorities copied into the root"
fi

inside() {  # a login-like shell in the root, as CI runs: CI=true, no stdin
  chroot "$root" /usr/bin/env -i HOME=/root PATH=/usr/sbin:/usr/bin:/sbin:/bin CI=true \
    LANG=C.UTF-8 "${extra_ca[@]}" /bin/bash -c "cd /work/main && $1" </dev/null
}
declare -A rc secs
for cmd in scripts/run.sh scripts/test.sh; do
  step "inside: $cmd"
  t0=$SECONDS
  set +e
  inside "$cmd" > "$root.$(basename "$cmd" .sh).out" 2>&1
  rc[$cmd]=$?
  set -e
  secs[$cmd]=$((SECONDS - t0))
  cat "$root.$(basename "$cmd" .sh).out" >> "$log"
  step "$cmd: exit ${rc[$cmd]} after $((secs[$cmd] / 60)) min $((secs[$cmd] % 60)) s"
done

echo
echo "== fresh_machine_check summary ($(date -u +%F)) =="
echo "root: debootstrap --variant=minbase bookworm + git, ca-certificates; checkout $(git -C "$here" rev-parse --short HEAD)"
for cmd in scripts/run.sh scripts/test.sh; do
  out="$root.$(basename "$cmd" .sh).out"
  echo "-- $cmd: exit ${rc[$cmd]}, $((secs[$cmd] / 60)) min $((secs[$cmd] % 60)) s"
  grep -E "^bootstrap: |tests passed|tests failed|HIL run|tracking error|robot  |tsan_check: |The following tests|^\s+[0-9]+ - " "$out" | head -25 | sed 's/^/   /'
done
echo "full log: $log"
[[ ${rc[scripts/run.sh]} -eq 0 && ${rc[scripts/test.sh]} -eq 0 ]]
