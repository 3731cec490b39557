#!/bin/sh
# The kinematic-agreement study (README.md here): every cell on both backends, one worker each.
# Run from the repository root; results go to runs/kinematic-agreement/ (not committed), the
# rows are copied here by read.sh. Resumable: run it again to finish what was cut short.
# Arguments: the backends to run (default both), e.g. `run.sh pybullet` beside `run.sh kinematic`.
set -e
PY=${PY:-.venv/bin/python}
OUT=runs/kinematic-agreement
COMMON="--methods dwa3,d3dwa --policy-seeds 0 --axes '' --profiles none,real,harsh --seeds 1 --workers 1"
for backend in ${*:-kinematic pybullet}; do
  for recovery in none nav2; do
    eval "$PY -m d3dwa_bullet.cli sweep $COMMON --worlds '' --layouts 4 --recovery $recovery \
      --backend $backend --out $OUT/r-style-$recovery-$backend"
    eval "$PY -m d3dwa_bullet.cli sweep $COMMON --suite barn --split train \
      --world-ids 1,26,51,76,101,127,152,177,202,227,253,278 --recovery $recovery \
      --backend $backend --out $OUT/barn-$recovery-$backend"
  done
done
