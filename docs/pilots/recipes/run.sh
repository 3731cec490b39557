#!/bin/sh
# Issue 79's plan sweep: plan.md's command, run from the repository root of a checkout that holds all 30 seeds in
# recipe-seeds/ and stays at one commit until the sweep ends (plan.json records the code; a resume on other code is
# refused). Resumable: run it again to go on where it was cut. WORKERS=1 when the machine is shared.
set -e
PY=${PY:-.venv/bin/python}
$PY -m d3dwa_bullet.cli sweep --plan docs/pilots/recipes/plan.yaml --policy-root recipe-seeds --suite barn,barn-style \
  --split all --world-ids "$(seq -s, 0 10 290)" --count 30 --world-seed 2147493648 --styles R1-style,R2-style,R3-style \
  --layouts 134 --layout-seed 2147493648 --axes '' --profiles none,real,harsh --recovery nav2 --seeds 1 \
  --workers "${WORKERS:-2}" --out "${OUT:-runs/recipes}" \
  --methods dwa3,random@10,random-weights@10,d3dwa,d3dwa-weights,d3dwa-dr
