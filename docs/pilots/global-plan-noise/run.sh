#!/bin/sh
# Issue 80's remaining readings (README.md here), fixed before the first episode. Run from the repository
# root; results go to runs/gp-noise/ (not committed). Resumable: run it again to finish what was cut short.
# `run.sh barn` (BARN challenge under real and harsh, with and without --global-plan scan) and `run.sh rstyle`
# (the moonshot's fresh R-style layouts) may run side by side, one worker each.
# Both go in chunks that grow the same directories, so a run cut short by time leaves every directory holding
# the same worlds (pairs complete), never a choice made after reading results.
set -e
PY=${PY:-.venv/bin/python}
OUT=runs/gp-noise
BARN="--suite barn --split challenge --seeds 1 --methods dwa3,d3dwa --policy-seeds 0 --recovery nav2 --workers 1"
barn() {
  for last in 96 198 294; do               # 17, 34, 50 of the challenge worlds (0, 6, ..., last)
    ids=$(seq -s, 0 6 $last)
    for noise in real harsh; do
      for plan in scan none; do
        $PY -m d3dwa_bullet.cli eval $BARN --world-ids $ids --noise $noise --global-plan $plan \
          --out $OUT/barn-$noise-$plan
      done
    done
  done
}
rstyle_worlds() {  # the first $1 layouts of each style, generator seeds 2^31 + 60000 + i
  i=0; list=""
  while [ $i -lt "$1" ]; do
    s=$((2147483648 + 60000 + i))
    list="$list,R1-style-s$s,R2-style-s$s,R3-style-s$s"
    i=$((i + 1))
  done
  echo "${list#,}"
}
rstyle() {
  for plan in ${PLANS:-scan none}; do
    for n in 10 20 30; do
      $PY -m d3dwa_bullet.cli sweep --methods dwa3,d3dwa --policy-seeds 0 --axes '' --profiles none,real,harsh \
        --seeds 1 --workers 1 --styles '' --worlds "$(rstyle_worlds $n)" --recovery nav2 --global-plan $plan \
        --out $OUT/rstyle-$plan
    done
  done
}
for part in ${*:-barn rstyle}; do $part; done
