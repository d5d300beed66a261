#!/usr/bin/env bash
# The detector's figures (detector/README.md): runs `coins-detect detect` and writes one JSON
# report per run into OUT (default /tmp/coins-detect-figures). About 25 minutes on 2 idle cores.
#   bench/detect/figures.sh [BUILD_DIR] [OUT]
set -euo pipefail
BIN=${1:-build}/bin/coins-detect
OUT=${2:-/tmp/coins-detect-figures}
mkdir -p "$OUT"
run() { local name=$1; shift; echo "== $name: detect $*" >&2; "$BIN" detect "$@" --json > "$OUT/$name.json"; }

# 1. Paddle->Ball against the simulator's labels, and without each safeguard
BALL=(--env breakout --source Paddle --targets Ball --steps 1000000 --holdout 0.1 --active-steps 40000 --eval --eval-steps 500000)
run ball_1m "${BALL[@]}"
run ball_1m_nogate "${BALL[@]}" --proximity-gate false
run ball_1m_nocf "${BALL[@]}" --counterfactual-draws 0

# 2. steps of data before each link passes, with the linear Granger test on the same data
for s in 1000 2000 5000 10000 20000; do
  run action_$s --env breakout --source Action --steps $s --granger
done
for s in 20000 40000 60000 80000 120000; do
  run paddle_$s --env breakout --source Paddle --targets Ball --steps $s --granger --eval --eval-steps 100000
done
for s in 20000 40000 60000; do
  run paddle_goals_$s --env breakout --source Paddle --targets Ball --steps $s --policy goals
done

# 3. pushing
run push_action --env pushing --source Action --steps 20000 --granger --eval --eval-steps 10000
run push_gripper --env pushing --source Gripper --steps 50000 --policy goals --granger --eval --eval-steps 20000
