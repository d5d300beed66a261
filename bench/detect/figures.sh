#!/usr/bin/env bash
# The detector's figures (detector/README.md): runs `coins-detect detect` and writes one JSON
# report per run into OUT (default /tmp/coins-detect-figures). Takes about 20 minutes on 2 cores.
#   bench/detect/figures.sh [BUILD_DIR] [OUT]
set -euo pipefail
BIN=${1:-build}/bin/coins-detect
OUT=${2:-/tmp/coins-detect-figures}
mkdir -p "$OUT"
run() { local name=$1; shift; echo "== $name: detect $*" >&2; "$BIN" detect "$@" --json > "$OUT/$name.json"; }

# 1. Paddle->Ball against the simulator's labels (300k training steps, 500k fresh steps)
run ball_prox --env breakout --source Paddle --targets Ball --steps 300000 --eval --eval-steps 500000
run ball_noprox --env breakout --source Paddle --targets Ball --steps 300000 --eval --eval-steps 500000 --no-proximity-gate
run ball_nocf --env breakout --source Paddle --targets Ball --steps 300000 --eval --eval-steps 500000 --counterfactual-draws 0
run ball_goals --env breakout --source Paddle --targets Ball --steps 300000 --policy goals --eval --eval-steps 500000

# 2. steps of data before each link passes, with the linear Granger test on the same data
for s in 1000 2000 5000 10000 20000; do
  run action_$s --env breakout --source Action --steps $s --granger
done
for s in 10000 20000 40000 80000 160000; do
  run paddle_$s --env breakout --source Paddle --steps $s --granger --eval --eval-steps 100000
  run paddle_goals_$s --env breakout --source Paddle --targets Ball --steps $s --policy goals --granger
done

# 3. pushing
run push_action --env pushing --source Action --steps 20000 --granger --eval --eval-steps 10000
run push_gripper --env pushing --source Gripper --steps 50000 --policy goals --granger --eval --eval-steps 20000
