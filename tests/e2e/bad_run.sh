# Bad command-line input and run folders: --out where no folder can be, two runs into one folder,
# --resume of a folder with failed cells, reference --frames that wrap, images that never end or
# claim absurd sizes. Each is a clear error (exit 2) or, for --resume, a repair.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/config.yaml"
write_config "$cfg" "scenes: [cornell-box]"

# (5) --out under /proc, or onto an existing file: exit 2 naming --out, not a raw filesystem error.
expect_exit 2 "--out under /proc" -- "$PB" run "$cfg" --out /proc/photonbench-run
expect_match "--out /proc: names the option and the reason" "^error: --out /proc/photonbench-run: cannot create the run folder: " "$OUT"
: > "$WORK/a-file"
expect_exit 2 "--out onto a file" -- "$PB" run "$cfg" --out "$WORK/a-file"
expect_match "--out file: says so" "--out $WORK/a-file: exists and is not a folder" "$OUT"
expect_exit 2 "--resume of a folder that holds no run" -- "$PB" run "$cfg" --out "$WORK" --resume
expect_match "--resume: not a run folder" "is not a photonbench run folder \(no invocation.json\)" "$OUT"

# (4) Two runs started together into one new --out: one runs, the other is refused at once.
cat > "$cfg" <<YAML
name: lock
resolution: [64, 36]
frames: {warmup: 0, count: 4, metrics_every: 0}
scenes: [cornell-box]
plugin_dirs: [$TEST_PLUGINS]
techniques:
  - technique: direct
  - technique: sleeps
    params: {sleep_ms: 400}
YAML
run="$WORK/run"
"$PB" run "$cfg" --out "$run" > "$WORK/a.log" 2>&1 &
a=$!
"$PB" run "$cfg" --out "$run" > "$WORK/b.log" 2>&1 &
b=$!
wait "$a"; code_a=$?
wait "$b"; code_b=$?
codes="$(printf '%s\n' "$code_a" "$code_b" | sort | tr '\n' ' ')"
[ "$codes" = "0 2 " ] && pass "one run completes, the other is refused (exits $codes)" || fail "exit codes $code_a and $code_b; logs: $(cat "$WORK/a.log" "$WORK/b.log")"
expect_match "the refused run says the folder is in use" "is in use by another photonbench run \(pid [0-9]+\)" "$(cat "$WORK/a.log" "$WORK/b.log")"
expect_match "the run that ran has both cells ok" "^2$" "$(grep -c ',ok,' "$run/summary.csv")"
expect_exit 2 "a finished run folder is not reused" -- "$PB" run "$cfg" --out "$run"
expect_match "already holds a run" "already holds a run; use --resume" "$OUT"

# --resume redoes failed cells: kill the sleeps cell's process mid-run (as the OOM killer might),
# then resume; the failed attempt is kept in failed-attempts/.
run="$WORK/resume"
setsid "$PB" run "$cfg" --out "$run" > "$WORK/first.log" 2>&1 &
leader=$!
child=""
for _ in $(seq 1 600); do
  child=$(pgrep -f -- "__cell $run/? .*sleeps" | head -1)
  [ -n "$child" ] && ls -d "$run"/cells/.partial-*sleeps* > /dev/null 2>&1 && break
  sleep 0.1
done
[ -n "$child" ] && kill -KILL "$child"
wait "$leader"
code=$?
[ "$code" -eq 1 ] && pass "the run with a killed cell exits 1" || fail "exit $code: $(cat "$WORK/first.log")"
sleeps_cell=$(ls -d "$run"/cells/cornell-box__sleeps__* | head -1)
expect_match "the killed cell is recorded failed" "failed" "$(json_field "$sleeps_cell/cell.json" status)"
expect_exit 0 "--resume redoes the failed cell" -- "$PB" run "$cfg" --out "$run" --resume
expect_match "the complete cell is skipped" "complete already, skipped" "$OUT"
[ "$(printf '%s' "$OUT" | grep -c 'complete already, skipped')" -eq 1 ] && pass "only the ok cell skipped" || fail "skips: $OUT"
expect_match "the redone cell is ok" "^ok$" "$(json_field "$sleeps_cell/cell.json" status)"
aside="$run/failed-attempts/$(basename "$sleeps_cell")"
expect_match "the failed attempt is kept" "^failed$" "$(json_field "$aside/cell.json" status)"
[ -e "$aside/cell.log" ] && pass "the failed attempt's log is kept" || fail "no log in $aside"
expect_match "summary: both cells ok" "^2$" "$(grep -c ',ok,' "$run/summary.csv")"

# (3) reference --frames: negative or wrapping frame numbers are errors, not 4294967295 frames.
for frames in -1 0:4294967295 5:2 1e3 ""; do
  [ -z "$frames" ] && frames="0:"
  expect_exit 2 "reference --frames '$frames'" -- timeout 60 "$PB" reference cornell-box --frames "$frames" \
    --resolution 16x16 --samples 2 --cache "$WORK/cache"
  expect_match "--frames '$frames': says what a frame is" "--frames: '$frames' is not FIRST:LAST or FRAME \(frames 0 to 1099999\)" "$OUT"
done
[ -z "$(ls -A "$WORK/cache" 2>/dev/null)" ] && pass "nothing rendered into the cache" || fail "the cache holds $(ls "$WORK/cache")"

# (9) An image that never ends, (5) one whose header claims 100000 x 100000 pixels.
data="$SRC/tests/data/metrics"
expect_exit 2 "metrics --reference /dev/zero" -- timeout 60 "$PB" metrics --reference /dev/zero --test "$data/ldr01_test.png"
expect_match "/dev/zero: not a regular file" "/dev/zero: not a regular file" "$OUT"
/usr/bin/python3 - "$WORK/huge.png" <<'PY'
import struct, sys, zlib
def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
header = struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0)  # 8-bit RGB
body = zlib.compress(b"\0" * 64)
open(sys.argv[1], "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", body) + chunk(b"IEND", b""))
PY
expect_exit 2 "metrics on a 100000 x 100000 header" -- timeout 60 "$PB" metrics --reference "$WORK/huge.png" --test "$data/ldr01_test.png"
expect_match "huge header: the size and the limit" "huge.png: a 100000 x 100000 image of 3 channels; images are 1 x 1 to 16384 x 16384" "$OUT"
finish
