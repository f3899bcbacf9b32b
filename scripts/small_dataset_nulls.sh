#!/usr/bin/env bash
# Datasets the base model itself simulated (no hidden effect: the right model, by
# construction), small ones: how `skidsteer diagnose` judges them by the number of
# commands and trials.  Issue 21 (stop 44) measured these before and after
# comparison.MIN_SPREAD_DOF and the rule that names no cause when the held-out runs
# repeat trained commands (docs/diagnose.md, "Compare" and "Fit").  10 s runs, seeded;
# 16 min on this 2-core machine.  Usage: scripts/small_dataset_nulls.sh OUT_DIR
set -euo pipefail
out=${1:?usage: scripts/small_dataset_nulls.sh OUT_DIR}
bin=${SKIDSTEER_VENV:-.venv}/bin
mkdir -p "$out"
#     name seed trials floor  omegas (deg/s)
cases=("A 11 3 concrete 30" "E 15 2 concrete 30" "B 12 2 tile 20 45"
       "D 14 2 carpet 15 30 45" "C 13 3 concrete 20 45" "F 21 4 concrete 30"
       "G 22 4 tile 45" "H 23 2 concrete 20 35 50" "I 24 3 carpet 25 50"
       "J 25 2 tile 15 30 45")
printf '| dataset | commands x trials | floor | verdict | base error (all runs) |\n|---|---|---|---|---|\n'
for spec in "${cases[@]}"; do
  read -r name seed trials floor omegas <<<"$spec"
  args=()
  for w in $omegas; do args+=(--omega "$w"); done
  "$bin/skidsteer" sweep --out "$out/$name/data" "${args[@]}" --build extended \
    --floor "$floor" --trials "$trials" --seed "$seed" --duration 10 --quiet --format csv >&2
  if "$bin/skidsteer" diagnose "$out/$name/data" --out "$out/$name/diag" --no-progress \
      --no-figures --cache "$out/cache" --json >"$out/$name/diagnose.json" 2>"$out/$name/error.txt"; then
    row=$("$bin/python" -c "import json,sys; d=json.load(open(sys.argv[1])); \
print(d['verdict'], '|', round(d['baseline_error_all_runs'], 2))" "$out/$name/diag/diagnosis.json")
  else
    row="error: $(cut -c1-80 "$out/$name/error.txt") ... | -"
  fi
  n=$(wc -w <<<"$omegas")
  echo "| $name (seed $seed) | $n x $trials | $floor | $row |"
done
