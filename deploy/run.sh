#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs COInS on Breakout on this machine,
# every process (actors, replay shards, learner, orchestrator) talking over Fast DDS.
# Extra arguments go to `coins run` (e.g. --steps 2000000 --actors 4).
set -euo pipefail
cd "$(dirname "$0")/.."
./deploy/build.sh
exec build/bin/coins run --config deploy/configs/breakout.yaml "$@"
