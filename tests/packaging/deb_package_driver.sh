#!/bin/bash
# Inside the booted Debian 12 root of deb_package_test.sh, as a systemd unit: the package's life
# under a real systemd. Writes PASS or the first FAIL to /results/verdict; the root powers off
# when this ends. /debs holds old.deb and new.deb (a newer version of it).
set -uo pipefail
phase=$(cat /results/phase)
echo "== phase $phase"
[[ "$phase" == baseline ]] && exit 0

verdict=/results/verdict
rm -f "$verdict"
fail() { echo "FAIL: $*" | tee -a "$verdict"; journalctl -u hyq-servod -u hyq-sim --no-pager | tail -40; exit 1; }
ok() { echo "ok: $*"; }
key=/etc/hyq/command.key

# install: the user, the key, the unit neither enabled nor started
dpkg -i /debs/old.deb || fail "dpkg -i old.deb"
getent passwd hyq >/dev/null || fail "no user hyq after the install"
[[ "$(stat -c '%U:%G %a' $key)" == "hyq:hyq 400" ]] ||
  fail "expected $key hyq:hyq mode 400, found $(stat -c '%U:%G %a' $key)"
key_sum=$(md5sum <$key)
[[ "$(systemctl is-enabled hyq-servod.service 2>&1)" == disabled ]] ||
  fail "expected the unit disabled after the install, found $(systemctl is-enabled hyq-servod.service 2>&1)"
systemctl is-active --quiet hyq-servod.service && fail "the install started the unit"
ok "installed: user hyq, $key hyq:hyq 0400, unit disabled and inactive"
for f in hyq_servo.yaml hyq_servo_sim.yaml hyq_hal.yaml robots/hyq.urdf; do
  dpkg-query --control-show hyq-servo conffiles | grep -q "^/etc/hyq/$f$" || fail "/etc/hyq/$f is not a conffile"
done
# the installed tools find the installed configuration (tools/cli/install_paths.h)
hyq-servod --check >/dev/null || fail "hyq-servod --check with the default configuration (/etc/hyq)"
hyq-servod --help | grep -q "default /etc/hyq/hyq_servo.yaml" || fail "hyq-servod --help does not name /etc/hyq"
ok "hyq-servod --check finds /etc/hyq/hyq_servo.yaml"
echo "# an operator's edit" >>/etc/hyq/hyq_servo.yaml

# the unit against hyq-sim on the virtual CAN buses (UDP multicast on loopback)
ip link set lo up
ip route add 224.0.0.0/4 dev lo
mkdir -p /etc/systemd/system/hyq-servod.service.d
cat >/etc/systemd/system/hyq-servod.service.d/sim.conf <<'EOF'
[Service]
Environment=HYQ_SERVO_CONFIG=/etc/hyq/hyq_servo_sim.yaml
Environment="HYQ_SERVOD_ARGS=--commands --summary /tmp/servod.json"
EOF
systemctl daemon-reload
# hyq-sim as a transient unit, then the daemon's unit against it, until ACTIVE (the N-th time)
start_both() {
  systemd-run --unit=hyq-sim --quiet /usr/bin/hyq-sim --mode lockstep --quiet --summary "/results/sim$1.json" ||
    fail "systemd-run hyq-sim"
  sleep 0.5
  systemctl start hyq-servod.service || fail "systemctl start hyq-servod"
  for ((i = 0; i < 600; i++)); do
    (($(journalctl -u hyq-servod --no-pager -q | grep -c -- "-> active") >= $1)) && return 0
    sleep 0.1
  done
  fail "hyq-servod not ACTIVE after 60 s"
}
rm -f /tmp/servod.json
start_both 1
ok "hyq-servod ACTIVE under the unit (User=hyq, the command channel open with $key)"

sleep 6  # stand up and trot (lock-step: faster than real time)
systemctl stop hyq-servod.service
result=$(systemctl show -p Result --value hyq-servod.service)
status=$(systemctl show -p ExecMainStatus --value hyq-servod.service)
journalctl -u hyq-servod --no-pager -q | sed 's/^/  journal: /'
[[ "$result" == success && "$status" == 0 ]] || fail "expected Result=success, status 0; found $result, $status"
journalctl -u hyq-servod --no-pager -q | grep -q "controlled stop" || fail "no controlled stop in the journal"
cp /tmp/servod.json /results/servod.json || fail "no summary from hyq-servod"
systemctl stop hyq-sim.service
for ((i = 0; i < 50; i++)); do [[ -s /results/sim1.json ]] && break; sleep 0.1; done
ok "systemctl stop: a controlled stop, exit 0"

# upgrade: the operator's edit and the key survive
dpkg -i /debs/new.deb || fail "dpkg -i new.deb (the upgrade)"
[[ "$(dpkg-query -W -f '${Version}' hyq-servo)" == *+upgrade1 ]] || fail "the upgrade did not take"
grep -q "^# an operator's edit$" /etc/hyq/hyq_servo.yaml || fail "the upgrade lost the edit to a conffile"
[[ "$(md5sum <$key)" == "$key_sum" && "$(stat -c '%U:%G %a' $key)" == "hyq:hyq 400" ]] ||
  fail "the upgrade changed the command key"
hyq-servod --check >/dev/null || fail "hyq-servod --check after the upgrade"
ok "upgraded to $(dpkg-query -W -f '${Version}' hyq-servo): the conffile edit and the key kept"

# purge while the daemon runs, enabled: prerm stops it (a controlled stop); the enablement, the
# key, the user and group go with the package
systemctl enable hyq-servod.service 2>/dev/null || fail "systemctl enable hyq-servod"
start_both 2
dpkg --purge hyq-servo || fail "dpkg --purge hyq-servo"
systemctl is-active --quiet hyq-servod.service && fail "the purge left hyq-servod running"
(($(journalctl -u hyq-servod --no-pager -q | grep -c "controlled stop") == 2)) ||
  fail "expected the purge's controlled stop in the journal"
systemctl stop hyq-sim.service
rm -rf /etc/systemd/system/hyq-servod.service.d  # the test's own drop-in, as an operator's
systemctl daemon-reload
getent passwd hyq >/dev/null && fail "the purge left the user hyq"
getent group hyq >/dev/null && fail "the purge left the group hyq"
[[ -e /etc/hyq ]] && fail "the purge left /etc/hyq: $(ls -A /etc/hyq)"
[[ -e /etc/systemd/system/multi-user.target.wants/hyq-servod.service ]] && fail "the purge left the unit enabled"
ok "purged while running: a controlled stop first; nothing of the package left"
echo PASS >"$verdict"
