#!/usr/bin/env bash
# The state estimator against hyq-sim's truth through the loop (label "hil"): scripts/hil.sh,
# lock-step, the shipped configuration, then scripts/estimator_accuracy.py with the bounds the
# estimator is held to (docs/estimation.md, "Accuracy"); it exits 1 naming each figure over its
# bound.
#
#   estimator_accuracy_test.sh BUILD_DIR OUT_DIR ideal_mu0.1 | realistic_mu0.1 | ideal_mu1.0 | stand_bias
#
# ideal_mu0.1, realistic_mu0.1, ideal_mu1.0: 10 s of trot (two-stage ID); over the trot the
#   horizontal velocity error RMS <= 0.6 cm/s (ideal, mu 0.1) or 1.0 cm/s (the others), the
#   largest <= 8 cm/s, the yaw drift <= 10 mrad; on the ideal plant at mu 1.0 also the settling
#   after the stop <= 2 cm/s RMS (the legs fold under the trunk at up to 5 cm/s; on mu 0.1 the
#   damped robot slides on its belly: docs/estimation.md).
# stand_bias: 8 s of standing on the realistic plant: the gyro bias after 5 s of standing still
#   within 20 % of the one hyq-sim drew.
set -euo pipefail
build="$1" out="$2" case="$3"
here="$(cd "$(dirname "$0")/../.." && pwd)"
rm -rf "$out"
mkdir -p "$(dirname "$out")"
hil=("$here/scripts/hil.sh" --build "$build" --out "$out" --quiet --sim-arg=--truth-every --sim-arg=1)
acc=(/usr/bin/python3 "$here/scripts/estimator_accuracy.py" "$out")
case "$case" in
  ideal_mu0.1)
    "${hil[@]}" --duration 10
    "${acc[@]}" --max-trot-vel-rms 0.6 --max-trot-vel-max 8 --max-yaw-drift 10 ;;
  realistic_mu0.1)
    # the yaw: the drawn z gyro bias (-2.1 mrad/s) would turn it by 21 mrad over the trot; the
    # 2 s stand-up is too short to learn it fully (9-11 mrad measured, docs/estimation.md)
    "${hil[@]}" --duration 10 --sim-arg=--profile --sim-arg=realistic
    "${acc[@]}" --max-trot-vel-rms 1.0 --max-trot-vel-max 8 --max-yaw-drift 15 ;;
  ideal_mu1.0)
    "${hil[@]}" --duration 10 --mu 1.0
    "${acc[@]}" --max-trot-vel-rms 1.0 --max-trot-vel-max 8 --max-yaw-drift 10 --max-rest-vel-rms 2.0 ;;
  stand_bias)
    "${hil[@]}" --duration 8 --reference stand --sim-arg=--profile --sim-arg=realistic
    "${acc[@]}" --max-gyro-bias-error 20 ;;
  *) echo "estimator_accuracy_test.sh: unknown case '$case'" >&2; exit 2 ;;
esac
