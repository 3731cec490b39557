#!/bin/sh
# The kinematic-agreement study, second run (README.md here): every cell on the backends given (default
# both), one worker each, e.g. `run.sh pybullet` beside `run.sh kinematic`. Run from the repository root;
# results go to runs/kinematic-agreement-2/ (not committed); tools/experiments/kinematic_agreement.py reads
# them and copies the rows here. Resumable: run it again to finish what was cut short.
# Layouts fixed before any episode: R1/R2/R3-style generator seeds 2^31 + 50000 ... + 50029 (30 a style,
# 90 layouts) and 12 BARN-style worlds from seed 2^31 + 50000 (2147533648), none evaluated before.
# They run in rounds, each extending every directory by a prefix of the same lists (R-style layouts a
# style : BARN-style worlds), so that a run stopped by the clock covers every cell with the layouts it
# reached. STOP_AT (seconds since the epoch) starts no sweep after that time.
set -e
PY=${PY:-.venv/bin/python}
OUT=${OUT:-runs/kinematic-agreement-2}
FIRST=2147533648
ROUNDS=${ROUNDS:-"5:2 10:4 15:6 20:8 25:10 30:12"}
METHODS=dwa3,d3dwa,d3dwa-weights,d3dwa-dr,random@10
COMMON="--methods $METHODS --policy-seeds 0 --axes '' --seeds 1 --workers 1"
late() { [ -n "$STOP_AT" ] && [ "$(date +%s)" -ge "$STOP_AT" ]; }
for backend in ${*:-kinematic pybullet}; do
  for round in $ROUNDS; do
    per_style=${round%%:*}; barn=${round##*:}
    worlds=$($PY -c "print(','.join(f'{s}-style-s{$FIRST + i}' for s in ('R1', 'R2', 'R3') for i in range($per_style)))")
    # the layer on under every profile, then the paper's stack (no layer) under `none`
    for layer in "nav2 none,real,harsh" "none none"; do
      late && exit 0
      recovery=${layer%% *}; profiles=${layer##* }
      eval "$PY -m d3dwa_bullet.cli sweep $COMMON --profiles $profiles --worlds $worlds --styles '' \
        --recovery $recovery --backend $backend --out $OUT/r-style-$recovery-$backend"
    done
    for layer in "nav2 none,real,harsh" "none none"; do
      late && exit 0
      recovery=${layer%% *}; profiles=${layer##* }
      eval "$PY -m d3dwa_bullet.cli sweep $COMMON --profiles $profiles --suite barn-style --count $barn \
        --world-seed $FIRST --recovery $recovery --backend $backend --out $OUT/barn-style-$recovery-$backend"
    done
  done
done
