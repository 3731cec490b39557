#!/bin/sh
# Read what run.sh wrote (README.md here): the plan's looks (its headline, the robot score, per cell and look), then
# each method with against without the plan on the worlds both sides ran, by `d3dwa compare` (success and BARN's
# score beside the headline; they decide nothing).
PY=${PY:-.venv/bin/python}
OUT=${OUT:-runs/gp-sequential}
cat "$OUT/looks.md"
for m in dwa3 d3dwa; do
  $PY -m d3dwa_bullet.cli compare "$OUT/global-plan-scan" --against "$OUT/global-plan-none" --methods "$m,$m"
done
