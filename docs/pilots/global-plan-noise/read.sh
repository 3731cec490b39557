#!/bin/sh
# Read what run.sh wrote (README.md here): each method with against without the plan, paired by world, per
# profile (`d3dwa compare`, its JSON kept in runs/gp-noise/read/ and its page rows printed), then the pooled
# collisions, the moonshot's cells and the failures under a plan.
PY=${PY:-.venv/bin/python}
OUT=runs/gp-noise
mkdir -p $OUT/read
cmp() {  # name, A directory, B directory, method
  $PY -m d3dwa_bullet.cli compare "$2" --against "$3" --methods "$4,$4" --json > "$OUT/read/$1.json"
}
for noise in real harsh; do
  for m in dwa3 d3dwa; do cmp "$m-$noise" $OUT/barn-$noise-scan $OUT/barn-$noise-none $m; done
done
cmp dwa3-none $OUT/barn-none-scan-dwa3 $OUT/barn-none-none dwa3
cmp d3dwa-none $OUT/barn-none-scan-d3dwa $OUT/barn-none-none d3dwa
cmp d3dwa-s1to4-none $OUT/barn-none-scan-d3dwa-s1to4 $OUT/barn-none-none-d3dwa-s1to4 d3dwa
$PY -m tools.experiments.global_plan_readings --compare $OUT/read/*.json
$PY -m tools.experiments.global_plan_readings $OUT/*-*/
