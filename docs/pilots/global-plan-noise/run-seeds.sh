#!/bin/sh
# d3dwa training seeds 1-4 on BARN challenge, no noise, with (`run-seeds.sh scan`) and without (`run-seeds.sh none`)
# the plan, in the chunks run.sh uses. Run from the repository root; resumable; the two may run side by side.
set -e
PY=${PY:-.venv/bin/python}
for last in 96 198 294; do
  ids=$(seq -s, 0 6 $last)
  $PY -m d3dwa_bullet.cli eval --suite barn --split challenge --seeds 1 --methods d3dwa --policy-seeds 1-4 \
    --recovery nav2 --workers 1 --world-ids $ids --global-plan $1 --out runs/gp-noise/barn-none-$1-d3dwa-s1to4
done
