#!/usr/bin/env bash
# hyq-viewer --log: a short HIL run recorded by lcm-logger (scripts/hil.sh, with hyq-sim's truth)
# is played back paused; viewer_page.mjs seeks with the page's slider (the joint-state cycle shown
# is the last one lcm-logger had received by that log time), resumes at speed 0.5, pauses, and
# sends garbage controls, which are ignored.
#
#   viewer_log_test.sh BUILD_DIR SOURCE_DIR ARTIFACT_DIR        (run inside tests/drivers/in_netns.sh)
#
# Artefacts: ARTIFACT_DIR/viewer_log.png, the logs. Exit 0 pass, 1 fail, 77 skipped.
set -uo pipefail
build="${1:?build dir}" src="${2:?source dir}" art="${3:?artifact dir}"
source "$(dirname "$0")/viewer_common.sh"
viewer_preflight
rm -f "$art/viewer_log.png"

# the UDP buses (about 7x real time): the page's checks want a log of about a second of wall time
HYQ_HIL_NETNS=1 "$src/scripts/hil.sh" --duration 3 --transport udp --build "$build" --out "$work/hil" --quiet \
  --sim-arg --lcm-truth || fail "scripts/hil.sh exited $?"
"$build/tools/hyq-lcm-export/hyq-lcm-export" "$work/hil/telemetry.lcmlog" "$work/csv" ||
  fail "hyq-lcm-export could not decode the run's log"
viewer_start --log "$work/hil/telemetry.lcmlog" --paused
# HTTP garbage, an oversized header, a POST and a path outside the page: answered or dropped,
# never a crash
for req in $'garbage\r\n\r\n' "GET / HTTP/1.1"$'\r\n'"X: $(head -c 20000 /dev/zero | tr '\0' a)"$'\r\n\r\n' \
           $'POST /ws HTTP/1.1\r\nConnection: close\r\nContent-Length: 3\r\n\r\nabc' \
           $'GET /../../etc/passwd HTTP/1.1\r\nConnection: close\r\n\r\n'; do
  ( trap '' PIPE
    exec 3<>/dev/tcp/127.0.0.1/8087 && printf '%s' "$req" >&3 && timeout 2 head -c 200 <&3 >>"$work/garbage.log"
  ) 2>/dev/null
done
grep -q 'root:' "$work/garbage.log" && fail "a path outside the page was served"
grep -q '405 Method Not Allowed' "$work/garbage.log" || fail "a POST was not refused (405)"
grep -q '404 Not Found' "$work/garbage.log" || fail "/../../etc/passwd was not refused (404)"
kill -0 "$viewer_pid" 2>/dev/null || { cat "$work/hyq-viewer.log"; fail "hyq-viewer died on HTTP garbage"; }
node "$src/tests/viewer/viewer_page.mjs" log http://127.0.0.1:8087/ "$art" "$work"
page_rc=$?
((page_rc == 0)) || fail "the page checks failed"
kill -0 "$viewer_pid" 2>/dev/null || fail "hyq-viewer died"
echo "PASS (screenshot: $art/viewer_log.png)"
