#!/usr/bin/env bash
# Measures `photonbench compare` on real runs of this machine: its false-alarm rate on A/A pairs and
# whether it catches one pass made slower by the test-only delay injection (testing.slow_pass and
# testing.slow_factor, harness/src/cell/cell_runner.cpp). A measurement, not a test: it prints a table
# and the two counts (the criterion: "A/A flags no regression in 10 of 10 tries; a pass made 25% slower is
# flagged").
#
# Design: N independent pairs. Pair i makes K replicate runs of each of three sides, interleaved in time
# (round j runs A_i/j, A2_i/j and SLOW_i/j in a random order): A and A2 are the same build and config, SLOW has
# the named pass x FACTOR. It then compares the folders A_i with A2_i (A/A: exit 0 expected) and A_i with
# SLOW_i (exit 1 expected, the named pass "slower"). Replicates are how compare learns the run-to-run
# noise (its docstring); interleaving gives both sides of a comparison the same machine conditions, as
# a CI job should when it runs base and new builds; -k 1 measures the one-run-per-side case. Independent
# pairs rather than a chain, so that one odd run cannot spoil two verdicts.
#
# usage: tools/aa_check.sh [-n PAIRS] [-k RUNS] [-p PASS] [-f FACTOR] [-c CONFIG] [-b PHOTONBENCH]
#                          [-o DIR] [-x 'COMPARE ARGS'] [-- RUN ARGS (e.g. --set frames.count=24)]
#   defaults: 10 pairs, 8 runs per side, pass gbuffer, factor 1.25, configs/ci-perf.yaml,
#             build/photonbench, results/aa-check-<UTC time>; run folders and compare outputs are kept.
#   The runs inherit the environment; the log's header records the variables that change how lavapipe
#   runs (LP_NUM_THREADS, GLIBC_TUNABLES).
# exit: 0 when every A/A pair is clean and every slowed run is flagged on PASS, 1 otherwise, 2 bad usage.
set -u
here="$(cd "$(dirname "$0")/.." && pwd)"
pairs=10 reps=8 pass=gbuffer factor=1.25 config="$here/configs/ci-perf.yaml" pb="$here/build/photonbench"
out="" compare_args=""
usage() { sed -n '/^# usage:/,/^# exit:/p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }
while getopts "n:k:p:f:c:b:o:x:h" opt; do
  case "$opt" in
    n) pairs="$OPTARG" ;; k) reps="$OPTARG" ;; p) pass="$OPTARG" ;; f) factor="$OPTARG" ;; c) config="$OPTARG" ;;
    b) pb="$OPTARG" ;; o) out="$OPTARG" ;; x) compare_args="$OPTARG" ;; *) usage ;;
  esac
done
shift $((OPTIND - 1))
[ "${1:-}" = "--" ] && shift
run_args=("$@")
[[ "$pairs" =~ ^[1-9][0-9]*$ ]] || { echo "aa_check: -n wants a positive count" >&2; exit 2; }
[[ "$reps" =~ ^[1-9][0-9]*$ ]] || { echo "aa_check: -k wants a positive count" >&2; exit 2; }
[ -x "$pb" ] || { echo "aa_check: no photonbench executable at $pb (give -b)" >&2; exit 2; }
[ -f "$config" ] || { echo "aa_check: no config $config" >&2; exit 2; }
out="${out:-$here/results/aa-check-$(date -u +%Y%m%dT%H%M%SZ)}"
mkdir -p "$out" || exit 2
# Perf runs never run under validation layers (ctest sets PB_VALIDATION for its correctness checks).
unset PB_VALIDATION
read -r -a cmp_extra <<< "$compare_args"

log="$out/aa_check.log"
{
  echo "aa_check: $pairs pairs of $reps run(s) per side, config $config, slowed pass '$pass' x$factor"
  echo "  photonbench: $pb (source tree at $(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo '?'))"
  echo "  run args: ${run_args[*]:-(none)}   compare args: ${compare_args:-(none)}"
  echo "  env: LP_NUM_THREADS=${LP_NUM_THREADS-(unset)} GLIBC_TUNABLES=${GLIBC_TUNABLES-(unset)}"
  echo "  host: $(nproc) cpus, load average $(cut -d' ' -f1-3 /proc/loadavg) at start; out: $out"
} | tee "$log"

run_one() {  # run_one NAME [extra args]: one run; its console output goes to NAME.log
  local name="$1"
  shift
  mkdir -p "$(dirname "$out/$name")"
  "$pb" run "$config" --out "$out/$name" "${run_args[@]}" "$@" > "$out/$name.log" 2>&1
  local rc=$?
  [ "$rc" -eq 0 ] || echo "  warning: run $name exited $rc (see $out/$name.log)" | tee -a "$log"
}

# Reads a compare --json file: "<flags or ->|<PASS change%>|<PASS limit%>|<PASS verdicts>|<closest call>"
summarise() {
  /usr/bin/python3 - "$1" "$pass" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
slower = sorted({r["pass_name"] for r in d["passes"] if r["verdict"] == "slower"})
other = [s["verdict"] for s in d["statuses"] if s["verdict"] not in ("same",)]
worse = sorted({r["metric"] for r in d["metrics"] if r["verdict"] == "worse"})
flags = slower + [f"metric:{m}" for m in worse] + [f"cell:{v}" for v in other]
rows = [r for r in d["passes"] if r["pass_name"] == sys.argv[2]]
def f(v, fmt):
    return "" if v is None else fmt.format(v)
# One cell per pass row; with several cells, the worst (largest) change of the named pass is shown.
row = max(rows, key=lambda r: (r["change_pct"] if r["change_pct"] is not None else -1e9)) if rows else None
verdicts = ",".join(sorted({r["verdict"] for r in rows})) or "absent"
# The pass whose change came closest to its limit (the A/A margin): "change (limit) cell/pass".
tested = [r for r in d["passes"] if r["change_pct"] is not None and r["limit_pct"]]
worst = max(tested, key=lambda r: abs(r["change_pct"]) / r["limit_pct"]) if tested else None
worst_text = (f"{worst['change_pct']:+.1f}% ({worst['limit_pct']:.1f}%) {worst['pass_name']}" if worst else "")
print("|".join([",".join(flags) or "-", f(row and row["change_pct"], "{:+.1f}%"),
                f(row and row["limit_pct"], "{:.1f}%"), verdicts, worst_text]))
PY
}

aa_clean=0 slow_flagged=0
table=("| pair | A/A exit | A/A flagged | A/A worst change (limit) | slowed exit | $pass change (limit) | $pass verdict(s) | slowed-run flagged |"
       "|--:|--:|---|--:|--:|--:|---|---|")
for i in $(seq 1 "$pairs"); do
  t0=$(date +%s)
  for j in $(seq 1 "$reps"); do
    # A fresh random order each round, so no side keeps one slot of a periodic background load.
    for side in $(printf '%s\n' A A2 SLOW | shuf); do
      case "$side" in
        A) run_one "A$i/$j" ;;
        A2) run_one "A2-$i/$j" ;;
        SLOW) run_one "SLOW$i/$j" --set "testing.slow_pass=$pass" --set "testing.slow_factor=$factor" ;;
      esac
    done
  done
  "$pb" compare "$out/A$i" "$out/A2-$i" "${cmp_extra[@]}" --out "$out/aa$i.md" --json "$out/aa$i.json" > /dev/null 2>&1
  aa_rc=$?
  "$pb" compare "$out/A$i" "$out/SLOW$i" "${cmp_extra[@]}" --out "$out/slow$i.md" --json "$out/slow$i.json" > /dev/null 2>&1
  slow_rc=$?
  aa_sum="?|||" slow_sum="?|||"
  [ -f "$out/aa$i.json" ] && aa_sum="$(summarise "$out/aa$i.json")"
  [ -f "$out/slow$i.json" ] && slow_sum="$(summarise "$out/slow$i.json")"
  IFS='|' read -r aa_flags _ _ _ aa_worst <<< "$aa_sum"
  IFS='|' read -r s_flags s_change s_limit s_verdicts _ <<< "$slow_sum"
  [ "$aa_rc" -eq 0 ] && aa_clean=$((aa_clean + 1))
  [ "$slow_rc" -eq 1 ] && [[ ",$s_verdicts," == *",slower,"* ]] && slow_flagged=$((slow_flagged + 1))
  line="| $i | $aa_rc | $aa_flags | $aa_worst | $slow_rc | $s_change ($s_limit) | $s_verdicts | $s_flags |"
  table+=("$line")
  echo "  pair $i done in $(( $(date +%s) - t0 )) s, load $(cut -d' ' -f1 /proc/loadavg): $line" | tee -a "$log"
done

{
  echo
  printf '%s\n' "${table[@]}"
  echo
  echo "A/A pairs with no regression flagged: $aa_clean of $pairs"
  echo "slowed runs flagged ('$pass' x$factor reported slower, exit 1): $slow_flagged of $pairs"
  echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)"
} | tee -a "$log"
[ "$aa_clean" -eq "$pairs" ] && [ "$slow_flagged" -eq "$pairs" ]
