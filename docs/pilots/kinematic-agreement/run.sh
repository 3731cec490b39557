#!/bin/sh
# The kinematic-agreement study (README.md here): every cell on the backends given (default both),
# one worker each, e.g. `run.sh pybullet` beside `run.sh kinematic`. Run from the repository root;
# results go to runs/kinematic-agreement/ (not committed), read.sh reads them and copies the rows
# here. Resumable: run it again to finish what was cut short. FAMILIES="barn" (or "r-style")
# runs one family only, e.g. beside another run.sh on the other (a directory being written is
# refused, not shared: dir_lock).
set -e
PY=${PY:-.venv/bin/python}
OUT=runs/kinematic-agreement
COMMON="--methods dwa3,d3dwa --policy-seeds 0 --axes '' --profiles none,real,harsh --seeds 1 --workers 1"
BARN_IDS=1,51,101,152,202,253
FAMILIES=${FAMILIES:-r-style barn}
for backend in ${*:-kinematic pybullet}; do
  for recovery in none nav2; do
    case "$FAMILIES" in *r-style*) ;; *) continue ;; esac
    eval "$PY -m d3dwa_bullet.cli sweep $COMMON --worlds '' --layouts 4 --recovery $recovery \
      --backend $backend --out $OUT/r-style-$recovery-$backend"
  done
  for recovery in none nav2; do
    case "$FAMILIES" in *barn*) ;; *) continue ;; esac
    eval "$PY -m d3dwa_bullet.cli sweep $COMMON --suite barn --split train --world-ids $BARN_IDS \
      --recovery $recovery --backend $backend --out $OUT/barn-$recovery-$backend"
  done
done
