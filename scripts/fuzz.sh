#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz/: config, set, scene, obj, gltf) into build-fuzz/ with
# Debian's clang-14 (AddressSanitizer and UndefinedBehaviorSanitizer on) and runs each from its seed
# corpus tests/fuzz/corpus/<target>/, growing a working corpus in build-fuzz/corpus/<target>/.
#
#   scripts/fuzz.sh [--seconds N] [--runs N] [TARGET...]   (default: --seconds 30, all five)
#
# --seconds N: N seconds of one core for each target. With both limits a target stops at whichever
# comes first.
# .ci/run runs each target for a bounded time. A finding (a crash, a sanitizer report, an exception
# other than pb::InputError, an input slower than 30 s of a core or one using more than 4 GiB)
# stops that target, leaves the input in build-fuzz/findings/<target>/ and makes the script exit 1;
# reproduce it with build-fuzz/fuzz_<target> FILE.
set -euo pipefail
cd "$(dirname "$0")/.."

limit=()
seconds=
targets=()
while (($#)); do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --runs) limit+=(-runs="$2"); shift 2 ;;
    -h | --help) sed -n '2,13p' "$0"; exit 0 ;;
    *) targets+=("$1"); shift ;;
  esac
done
((${#targets[@]})) || targets=(config set scene obj gltf)
[[ -n "$seconds" || ${#limit[@]} -gt 0 ]] || seconds=30

cmake -S tests/fuzz -B build-fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++-14 > build-fuzz.log 2>&1 ||
  { cat build-fuzz.log; exit 1; }
cmake --build build-fuzz -j "$(nproc)" >> build-fuzz.log 2>&1 || { cat build-fuzz.log; exit 1; }

# AddressSanitizer keeps freed memory in a quarantine to catch use after free; its default 256 MiB,
# with the allocator's caches, grew a 10^7-run target past 1 GiB by 600,000 runs (measured: 537 MiB
# peak at 60,000 runs, 86 MiB with a 1 MiB quarantine), towards the 4 GiB limit below that reports
# a finding. 64 MiB still holds thousands of recent frees.
export ASAN_OPTIONS="${ASAN_OPTIONS:-quarantine_size_mb=64}"

# The targets run side by side, all at once (each fuzzer is one process on one core). With more
# targets than cores each gets a core's share, so its time limit and its slow-input limit (both
# wall time in libFuzzer) grow by targets / cores: N seconds of one core each, in N x targets /
# cores seconds of wall time. (In rounds of one target a core, five targets on two cores took
# 3 N, the last round leaving a core idle.)
cores=$(nproc)
share=(1 1)  # wall seconds per core-second: numerator, denominator
((${#targets[@]} <= cores)) || share=("${#targets[@]}" "$cores")
wall() { echo $((($1 * share[0] + share[1] - 1) / share[1])); }
[[ -z "$seconds" ]] || limit+=(-max_total_time="$(wall "$seconds")")
slow=$(wall 30)
fuzz_one() {
  local target=$1 corpus="build-fuzz/corpus/$1" findings="build-fuzz/findings/$1"
  local log="build-fuzz/$1.log" start=$SECONDS outcome runs
  mkdir -p "$corpus" "$findings"
  cp -n tests/fuzz/corpus/"$target"/* "$corpus"/
  if "build-fuzz/fuzz_$target" "${limit[@]}" -timeout=$slow -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$findings/" "$corpus" > "$log" 2>&1; then
    outcome="no finding"
  else
    outcome="FINDING (see $log, input in $findings/)"
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  echo "fuzz_$target: $runs runs in $((SECONDS - start)) s, corpus $(ls "$corpus" | wc -l) inputs: $outcome"
  [[ "$outcome" == "no finding" ]] || { tail -40 "$log"; return 1; }
}

status=0
pids=()
for target in "${targets[@]}"; do
  fuzz_one "$target" &
  pids+=($!)
done
for pid in "${pids[@]}"; do wait "$pid" || status=1; done
exit "$status"
