#!/bin/sh
# The carrot pilot and its one challenge run (README.md here), fixed before the first episode. Run from the
# repository root; results go to runs/carrot/ (not committed). Resumable: run it again to finish what was cut short.
#   run.sh pilot                   BARN train, 50 worlds, DWA III and d3dwa seed 0, --carrot along against sight
#   RULE=along|sight run.sh none   BARN challenge, no noise, both rules, the pilot's pick (RULE) first
#   RULE=along|sight run.sh noise  BARN challenge, real and harsh, both rules, RULE first
# Every part grows its directories in chunks of worlds, so a run cut short by time leaves both sides of every
# comparison on the same worlds.
set -e
PY=${PY:-.venv/bin/python}
OUT=runs/carrot
COMMON="--seeds 1 --methods dwa3,d3dwa --policy-seeds 0 --recovery nav2 --global-plan scan --workers 1"
train_ids() {  # every fifth world of BARN's train split, ascending: 1, 7, 13, ... (the first $1 of them)
  $PY -c "from d3dwa_bullet.world.barn import barn_split_ids as s; print(','.join(map(str, s('train')[::5][:$1])))"
}
pilot() {
  for n in 25 50; do
    for rule in sight along; do
      $PY -m d3dwa_bullet.cli eval --suite barn --split train --world-ids "$(train_ids $n)" $COMMON \
        --carrot $rule --out $OUT/pilot-$rule
    done
  done
}
need_rule() {
  case "$RULE" in
    along) other=sight ;;
    sight) other=along ;;
    *) echo "run.sh: RULE must be along or sight (the pilot's pick)" >&2; exit 2 ;;
  esac
}
none() {  # both rules, the pilot's pick first, paired by world in one code version
  need_rule
  for last in 96 198 294; do      # 17, 34, 50 of the challenge worlds (0, 6, ..., last)
    for rule in $RULE $other; do
      $PY -m d3dwa_bullet.cli eval --suite barn --split challenge --world-ids "$(seq -s, 0 6 $last)" $COMMON \
        --carrot $rule --out $OUT/challenge-none-$rule
    done
  done
}
noise() {  # real and harsh, both rules, the pilot's pick first
  need_rule
  for last in 96 198 294; do
    for profile in real harsh; do
      for rule in $RULE $other; do
        $PY -m d3dwa_bullet.cli eval --suite barn --split challenge --world-ids "$(seq -s, 0 6 $last)" $COMMON \
          --noise $profile --carrot $rule --out $OUT/challenge-$profile-$rule
      done
    done
  done
}
for part in ${*:-pilot}; do $part; done
