# A config run as two shards at once, sharing one reference cache, then merged, equals the same
# config run in one place, cell for cell; merge refuses missing, duplicated and foreign shards.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/sharded.yaml"
# Four cells of one path class (direct), so both shards need the same reference frame; 512 samples
# make its render take long enough (a second or two) for the shards to overlap on it. The sanitized
# build's reference renderer is about 5 times slower (1.0 against 5.2 Mrays/s on this render,
# `photonbench reference` side by side: 13.5 s against 3.0 s for 512 samples), so it takes 96
# samples, which it renders in 3.0-3.2 s, as long as the Release build's 512. The checks hold at any
# count; the count only makes the shards overlap, so that one of them waits on the other's lock.
samples=512
[ -n "$SANITIZED" ] && samples=96
cat > "$cfg" <<YAML
name: sharded
resolution: [64, 36]
frames: {warmup: 1, count: 2, metrics_every: 2}
scenes: [cornell-box]
plugin_dirs: [$TEST_PLUGINS]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 128, 256]}
  - technique: throws_on_frame
    params: {throw_frame: 2}
reference: {samples: $samples}
YAML
# The reference cache is relative (results/reference-cache), so each working directory has its own:
# the shards share one, the run in one place renders its own.
mkdir -p "$WORK/alone" "$WORK/shared"
(cd "$WORK/alone" && "$PB" run "$cfg" --out "$WORK/whole" > "$WORK/whole.log" 2>&1)
[ $? -eq 1 ] && pass "the run in one place exits 1 (a failed cell)" || fail "whole run: $(tail -5 "$WORK/whole.log")"

(cd "$WORK/shared" && exec "$PB" run "$cfg" --shard 1/2 --out "$WORK/s1" > "$WORK/s1.log" 2>&1) &
first=$!
(cd "$WORK/shared" && exec "$PB" run "$cfg" --shard 2/2 --out "$WORK/s2" > "$WORK/s2.log" 2>&1) &
second=$!
wait "$first"; rc1=$?
wait "$second"; rc2=$?
[ $((rc1 + rc2)) -eq 1 ] && pass "both shards ran (exit $rc1, $rc2)" ||
  fail "shards exited $rc1, $rc2: $(tail -3 "$WORK/s1.log" "$WORK/s2.log")"
expect_match "a shard says which cells it runs" "shard 1/2, [0-9]+ of 4 cells \([0-9.]+% of the estimated work\)" "$(cat "$WORK/s1.log")"

# The shared reference frame was rendered by one shard and reused by the other, which waited for it.
rendered=$(cat "$WORK/s1.log" "$WORK/s2.log" | grep -c '^\[reference\].*: rendered in')
cached=$(cat "$WORK/s1.log" "$WORK/s2.log" | grep -c '^\[reference\].*: cached')
[ "$rendered" -eq 1 ] && [ "$cached" -eq 1 ] && pass "one shard rendered the reference, the other reused it" ||
  fail "reference rendered $rendered times, cached $cached times: $(grep -h '^\[reference\]' "$WORK/s1.log" "$WORK/s2.log")"
cache="$WORK/shared/results/reference-cache"
[ "$(ls "$cache"/*.json | wc -l)" -eq 2 ] && [ -z "$(ls -A "$cache" | grep -i tmp)" ] &&
  pass "the shared cache holds two whole entries and no temporary file" || fail "cache: $(ls -A "$cache")"

/usr/bin/python3 - "$WORK/s1/run.json" "$WORK/s2/run.json" <<'PY' && pass "the shards' cells are disjoint and cover the plan" || fail "shard cells"
import json, sys
a, b = (json.load(open(f))["shard"] for f in sys.argv[1:])
assert a["every_cell"] == b["every_cell"] and len(a["every_cell"]) == 4, (a, b)
assert not set(a["cells"]) & set(b["cells"]) and sorted(a["cells"] + b["cells"]) == sorted(a["every_cell"])
assert a["cells"] and b["cells"]
PY

expect_exit 1 "merge joins the shards (exit 1: a failed cell, as the run)" -- "$PB" merge "$WORK/merged" "$WORK/s1" "$WORK/s2"
expect_match "merge reports the failed cell" "FAILED cornell-box__throws_on_frame__" "$OUT"
compare="$(/usr/bin/python3 "$SRC/tests/e2e/shard_compare_runs.py" "$WORK/whole" "$WORK/merged")" &&
  pass "the merged run equals the run in one place: $(echo "$compare" | tail -1)" || fail "merged vs whole: $compare"
/usr/bin/python3 - "$WORK/merged/run.json" <<'PY' && pass "run.json records both shards" || fail "merged run.json"
import json, sys
run = json.load(open(sys.argv[1]))
assert [s["index"] for s in run["shards"]] == [1, 2] and run["cells"] == 4 and "shard" not in run, run
assert all(s["host"] and s["start"] and s["end"] for s in run["shards"]), run["shards"]
PY

# Errors name what is wrong and write nothing.
expect_exit 2 "a missing shard is an error" -- "$PB" merge "$WORK/m-missing" "$WORK/s1"
expect_match "... naming its cells and the shard" "cell\(s\) missing, from shard 2/2, not given to merge: cornell-box__" "$OUT"
[ ! -e "$WORK/m-missing/run.json" ] && pass "nothing merged on error" || fail "merge wrote a run despite the error"
expect_exit 2 "a shard given twice is an error" -- "$PB" merge "$WORK/m-twice" "$WORK/s1" "$WORK/s2" "$WORK/s1"
expect_match "... naming the shard and the duplicated cells" "shard 1 is given 2 times.*cell cornell-box__[a-z_]+__[0-9a-f]+ is complete in 2 shards" "$(echo $OUT)"
cp -r "$WORK/s1" "$WORK/s1-killed"
killed=$(ls "$WORK/s1-killed/cells" | head -1)
rm -r "$WORK/s1-killed/cells/$killed"
expect_exit 2 "an incomplete shard is an error" -- "$PB" merge "$WORK/m-killed" "$WORK/s1-killed" "$WORK/s2"
expect_match "... naming the cell and its shard" "1 cell\(s\) missing, from $WORK/s1-killed \(shard 1/2\), incomplete: resume it.*: $killed" "$OUT"
(cd "$WORK/shared" && "$PB" run "$cfg" --shard 2/2 --out "$WORK/s2-other" --set frames.count=1 > /dev/null 2>&1)
expect_exit 2 "shards of different configs are an error" -- "$PB" merge "$WORK/m-other" "$WORK/s1" "$WORK/s2-other"
expect_match "... naming both config hashes" "different runs \(config hash [0-9a-f]{16}: .*; config hash [0-9a-f]{16}: " "$OUT"
expect_exit 2 "an unsharded run is not a shard" -- "$PB" merge "$WORK/m-whole" "$WORK/whole" "$WORK/s2"
expect_match "... saying so" "whole: not a shard" "$OUT"
expect_exit 2 "merging into a run folder is refused" -- "$PB" merge "$WORK/merged" "$WORK/s1" "$WORK/s2"

expect_exit 2 "--shard 3/2 is refused" -- "$PB" run "$cfg" --shard 3/2 --out "$WORK/bad"
expect_match "... with the expected form" "--shard: '3/2' is not I/N" "$OUT"
expect_exit 2 "--shard 0/2 is refused" -- "$PB" run "$cfg" --shard 0/2 --out "$WORK/bad"
expect_exit 2 "--resume as another shard is refused" -- "$PB" run "$cfg" --shard 2/2 --out "$WORK/s1" --resume
expect_match "... naming both" "started as shard 1/2, not 2/2" "$OUT"
finish
