#!/bin/sh
# Issue 80's sequential plan (plan.yaml, README.md here), fixed before its first episode. Run from the repository
# root; results go to runs/gp-sequential/ (not committed): the looks in it, each global-plan setting's episodes in
# its global-plan-scan/ and global-plan-none/. Resumable: run it again to finish what was cut short.
# No --global-plan: every cell names its two sides' settings. WORKERS=2 when both cores are free.
set -e
PY=${PY:-.venv/bin/python}
$PY -m d3dwa_bullet.cli sweep --plan docs/pilots/global-plan-sequential/plan.yaml \
  --suite barn --split challenge --methods dwa3,d3dwa --axes '' --profiles none,real,harsh --seeds 1 \
  --recovery nav2 --workers "${WORKERS:-1}" --out "${OUT:-runs/gp-sequential}"
