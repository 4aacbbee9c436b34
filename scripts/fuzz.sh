#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz/: config, set, scene, obj, gltf) into build-fuzz/ with
# Debian's clang-14 (AddressSanitizer and UndefinedBehaviorSanitizer on) and runs each from its seed
# corpus tests/fuzz/corpus/<target>/, growing a working corpus in build-fuzz/corpus/<target>/.
#
#   scripts/fuzz.sh [--seconds N] [--runs N] [TARGET...]   (default: --seconds 30, all five)
#
# With both limits a target stops at whichever comes first.
# .ci/run runs each target for a bounded time. A finding (a crash, a sanitizer report, an exception
# other than pb::InputError, an input slower than 30 s or one using more than 4 GiB) stops that
# target, leaves the input in build-fuzz/findings/<target>/ and makes the script exit 1; reproduce
# it with build-fuzz/fuzz_<target> FILE.
set -euo pipefail
cd "$(dirname "$0")/.."

limit=()
targets=()
while (($#)); do
  case "$1" in
    --seconds) limit+=(-max_total_time="$2"); shift 2 ;;
    --runs) limit+=(-runs="$2"); shift 2 ;;
    -h | --help) sed -n '2,13p' "$0"; exit 0 ;;
    *) targets+=("$1"); shift ;;
  esac
done
((${#limit[@]})) || limit=(-max_total_time=30)
((${#targets[@]})) || targets=(config set scene obj gltf)

cmake -S tests/fuzz -B build-fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++-14 > build-fuzz.log 2>&1 ||
  { cat build-fuzz.log; exit 1; }
cmake --build build-fuzz -j "$(nproc)" >> build-fuzz.log 2>&1 || { cat build-fuzz.log; exit 1; }

# AddressSanitizer keeps freed memory in a quarantine to catch use after free; its default 256 MiB,
# with the allocator's caches, grew a 10^7-run target past 1 GiB by 600,000 runs (measured: 537 MiB
# peak at 60,000 runs, 86 MiB with a 1 MiB quarantine), towards the 4 GiB limit below that reports
# a finding. 64 MiB still holds thousands of recent frees.
export ASAN_OPTIONS="${ASAN_OPTIONS:-quarantine_size_mb=64}"

# The targets run side by side, one a core (each fuzzer is one process on one core): N seconds of
# fuzzing each, in N x ceil(targets / cores) seconds of wall time.
fuzz_one() {
  local target=$1 corpus="build-fuzz/corpus/$1" findings="build-fuzz/findings/$1"
  local log="build-fuzz/$1.log" start=$SECONDS outcome runs
  mkdir -p "$corpus" "$findings"
  cp -n tests/fuzz/corpus/"$target"/* "$corpus"/
  if "build-fuzz/fuzz_$target" "${limit[@]}" -timeout=30 -rss_limit_mb=4096 -print_final_stats=1 \
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
cores=$(nproc)
pids=()
for target in "${targets[@]}"; do
  fuzz_one "$target" &
  pids+=($!)
  if ((${#pids[@]} >= cores)); then
    wait "${pids[0]}" || status=1
    pids=("${pids[@]:1}")
  fi
done
for pid in "${pids[@]}"; do wait "$pid" || status=1; done
exit "$status"
