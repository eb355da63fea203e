#!/usr/bin/env bash
# hyq-viewer live beside a HIL run: headless Chromium (playwright-core) opens the page, then
# scripts/hil.sh trots for 30 s (lock-step, niced: ~10 s of wall time, room for the screenshot
# on a loaded machine, where the browser draws slowly) in the same network
# namespace with hyq-sim's truth on LCM (--sim-arg --lcm-truth).
# viewer_page.mjs checks that the page connects, that the drawn robot moves as it trots, that the
# stance count shown equals HYQ_CONTACT of the same cycle in lcm-logger's record, that the truth
# ghost appears and that the page's commands are ignored (read-only).
#
#   viewer_hil_test.sh BUILD_DIR SOURCE_DIR ARTIFACT_DIR        (run inside tests/drivers/in_netns.sh)
#
# Artefacts: ARTIFACT_DIR/viewer_live.png (screenshot while trotting), viewer_live_samples.json,
# the logs. Exit 0 pass, 1 fail, 77 skipped (reason printed).
set -uo pipefail
build="${1:?build dir}" src="${2:?source dir}" art="${3:?artifact dir}"
source "$(dirname "$0")/viewer_common.sh"
viewer_preflight
rm -f "$art/viewer_live.png" "$art/viewer_live_samples.json"

viewer_start
node "$src/tests/viewer/viewer_page.mjs" live http://127.0.0.1:8087/ "$art" "$work" >"$work/page.log" 2>&1 &
page_pid=$!
pids+=("$page_pid")
for _ in $(seq 300); do
  [[ -e "$work/ready" ]] && break
  kill -0 "$page_pid" 2>/dev/null || { cat "$work/page.log"; fail "the page test exited before the run"; }
  sleep 0.1
done
[[ -e "$work/ready" ]] || { cat "$work/page.log"; fail "the page did not connect within 30 s"; }

# niced: lock-step runs as fast as two cores allow and would starve the browser (its virtual
# clock and the daemon's CPU-time deadlines do not care how long the run takes in wall time)
# the UDP buses (about 7x real time, not the shared memory's 20x): the browser needs seconds of
# wall time to draw its frames and take the screenshot while the robot trots
HYQ_HIL_NETNS=1 nice -n 19 "$src/scripts/hil.sh" --duration 30 --transport udp --build "$build" --out "$work/hil" --quiet \
  --sim-arg --lcm-truth
hil_rc=$?
cp "$work/hil/servod.log" "$work/hil/sim.log" "$art/" 2>/dev/null
((hil_rc == 0)) || fail "scripts/hil.sh exited $hil_rc"
"$build/tools/hyq-lcm-export/hyq-lcm-export" "$work/hil/telemetry.lcmlog" "$work/csv" ||
  fail "hyq-lcm-export could not decode the run's log"
sleep 0.5
touch "$work/done"
wait "$page_pid"
page_rc=$?
cat "$work/page.log"
((page_rc == 0)) || fail "the page checks failed (screenshot: $art/viewer_live.png)"
kill -0 "$viewer_pid" 2>/dev/null || fail "hyq-viewer died"
echo "PASS (screenshot: $art/viewer_live.png)"
