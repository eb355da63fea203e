#!/bin/sh
# Runs the libFuzzer binary for SECONDS on a scratch corpus seeded from SEEDS.
# Usage: run_fuzz.sh FUZZER SEEDS WORKDIR SECONDS [MAX_LEN (default 4096)]
set -u
fuzzer=$1 seeds=$2 work=$3 seconds=$4 max_len=${5:-4096}
if [ ! -x "$fuzzer" ]; then
  echo "run_fuzz: SKIP: $fuzzer is not built (cmake --build ... --target drivers_fuzz)" >&2
  exit 77
fi
mkdir -p "$work/corpus" "$work/artifacts"
exec "$fuzzer" -max_total_time="$seconds" -error_exitcode=3 -timeout_exitcode=3 -timeout=10 -rss_limit_mb=2048 -max_len="$max_len" -print_final_stats=1 \
  -artifact_prefix="$work/artifacts/" "$work/corpus" "$seeds"
