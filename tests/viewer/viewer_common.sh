# Shared by viewer_hil_test.sh and viewer_log_test.sh (sourced): skip checks, a work directory,
# process clean-up, hyq-viewer started and waited for.
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*"; exit 1; }

viewer_preflight() {
  [[ "${HYQ_NETNS:-}" == 1 ]] || skip "not in a private network namespace (tests/drivers/in_netns.sh could not unshare -n)"
  command -v node >/dev/null 2>&1 || skip "node not found (Debian: nodejs)"
  [[ -x /usr/bin/chromium ]] || skip "/usr/bin/chromium not found (Debian: chromium; scripts/bootstrap.sh)"
  [[ -d "$src/tools/hyq-viewer/web/node_modules/playwright-core" ]] ||
    skip "playwright-core not installed (scripts/bootstrap.sh runs npm ci in tools/hyq-viewer/web)"
  viewer="$build/tools/hyq-viewer/hyq-viewer"
  [[ -x "$viewer" ]] || fail "$viewer not built"
  [[ -s "$build/tools/hyq-viewer/web/app.js" ]] || skip "the page is not bundled (no node_modules when configured)"
  mkdir -p "$art"
  work="$(mktemp -d /tmp/hyq_viewer_test.XXXXXX)"
  pids=()
  trap viewer_cleanup EXIT
}

viewer_cleanup() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null; done
  cp "$work"/*.log "$art/" 2>/dev/null
  rm -rf "$work"
}

# viewer_start ARGS...: hyq-viewer on 127.0.0.1:8087 (a private namespace: the port is ours)
viewer_start() {
  "$viewer" --port 8087 "$@" >"$work/hyq-viewer.log" 2>&1 &
  viewer_pid=$!
  pids+=("$viewer_pid")
  for _ in $(seq 100); do
    grep -q '^hyq-viewer: http://' "$work/hyq-viewer.log" && return 0
    kill -0 "$viewer_pid" 2>/dev/null || { cat "$work/hyq-viewer.log"; fail "hyq-viewer exited early"; }
    sleep 0.1
  done
  cat "$work/hyq-viewer.log"
  fail "hyq-viewer did not start listening within 10 s"
}
