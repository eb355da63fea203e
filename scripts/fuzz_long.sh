#!/usr/bin/env bash
# Runs every libFuzzer target of the project for SECONDS each (default 600), two at a time, each
# from its committed seeds on a scratch corpus, and prints executions, coverage, corpus and
# crashes per target (the numbers of docs/security.md, "Fuzzing"). The test suite runs the same
# targets for 20-30 s each (ctest -L fuzz); this is the longer run.
#   scripts/fuzz_long.sh [SECONDS] [BUILD_DIR (default build/ci)]
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in -h|--help) sed -n '2,6p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
seconds=${1:-600} build=${2:-build/ci}
out="$build/fuzz-long"
rm -rf "$out" && mkdir -p "$out"
# name  binary  seeds  max_len
targets=(
  "drivers_frames  $build/tests/drivers/drivers_fuzzer  tests/drivers/fuzz_seeds  4096"
  "hal_frames      $build/tests/hal/fuzz_hal_frames     -                         4096"
  "command         $build/tests/servo/command_fuzzer    tests/servo/fuzz_seeds/command  4096"
  "config          $build/tests/servo/config_fuzzer     tests/servo/fuzz_seeds/config   16384"
  "id_problem      $build/tests/tools/id_problem_fuzzer tests/tools/fuzz_seeds/id_problem 4096"
  "qp_problem      $build/tests/tools/qp_problem_fuzzer tests/tools/fuzz_seeds/qp_problem 4096"
  "lcm_log         $build/tests/tools/lcm_log_fuzzer    tests/tools/fuzz_seeds/lcm_log    4096"
)
run() {
  local name=$1 bin=$2 seeds=$3 max_len=$4
  [[ -x "$bin" ]] || { echo "$name: not built ($bin)" > "$out/$name.log"; return; }
  mkdir -p "$out/$name/corpus" "$out/$name/artifacts"
  local s=(); [[ "$seeds" != - ]] && s=("$seeds")
  ASAN_OPTIONS=detect_leaks=1 "$bin" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$out/$name/artifacts/" \
    "$out/$name/corpus" "${s[@]}" > "$out/$name.log" 2>&1 || true
}
echo "fuzz_long: ${#targets[@]} targets x ${seconds} s, two at a time (about $(( (${#targets[@]} + 1) / 2 * seconds / 60 )) min); logs in $out"
i=0
for t in "${targets[@]}"; do
  # shellcheck disable=SC2086
  run $t &
  i=$((i + 1))
  if ((i % 2 == 0)); then wait; echo "fuzz_long: $i of ${#targets[@]} done"; fi
done
wait
printf '%-16s %10s %12s %8s %8s %8s\n' target seconds executions cov corpus crashes
for t in "${targets[@]}"; do
  read -r name _ <<<"$t"
  log="$out/$name.log"
  execs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "$log" | awk '{print $2}' || true)
  last=$(grep -E '^#[0-9]+' "$log" | grep -o 'cov: [0-9]*\|corp: [0-9]*' | tail -n 2 | awk '{print $2}' | paste -sd' ' || true)
  crashes=$(find "$out/$name/artifacts" -type f 2>/dev/null | wc -l)
  printf '%-16s %10s %12s %8s %8s %8s\n' "$name" "$seconds" "${execs:-?}" ${last:-? ?} "$crashes"
done
