#!/bin/sh
# The kinematic-agreement study, second run (README.md here): every cell on the backends given (default
# both), one worker each, e.g. `run.sh pybullet` beside `run.sh kinematic`. Run from the repository root;
# results go to runs/kinematic-agreement-2/ (not committed); tools/experiments/kinematic_agreement.py reads
# them and copies the rows here. Resumable: run it again to finish what was cut short.
# Layouts fixed before any episode: R1/R2/R3-style generator seeds 2^31 + 50000 ... + 50029 (30 a style,
# 90 layouts) and 12 BARN-style worlds from seed 2^31 + 50000 (2147533648), none evaluated before.
set -e
PY=${PY:-.venv/bin/python}
OUT=${OUT:-runs/kinematic-agreement-2}
FIRST=2147533648
R_PER_STYLE=30
BARN_COUNT=12
METHODS=dwa3,d3dwa,d3dwa-weights,d3dwa-dr,random@10
COMMON="--methods $METHODS --policy-seeds 0 --axes '' --seeds 1 --workers 1"
R_WORLDS=$($PY -c "print(','.join(f'{s}-style-s{$FIRST + i}' for s in ('R1', 'R2', 'R3') for i in range($R_PER_STYLE)))")
for backend in ${*:-kinematic pybullet}; do
  # the layer on under every profile, then the paper's stack (no layer) under `none`
  for layer in "nav2 none,real,harsh" "none none"; do
    set -- $layer
    eval "$PY -m d3dwa_bullet.cli sweep $COMMON --profiles $2 --worlds $R_WORLDS --styles '' \
      --recovery $1 --backend $backend --out $OUT/r-style-$1-$backend"
  done
  for layer in "nav2 none,real,harsh" "none none"; do
    set -- $layer
    eval "$PY -m d3dwa_bullet.cli sweep $COMMON --profiles $2 --suite barn-style --count $BARN_COUNT \
      --world-seed $FIRST --recovery $1 --backend $backend --out $OUT/barn-style-$1-$backend"
  done
done
