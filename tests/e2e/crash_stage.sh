# A cell that crashes after its last frame (a technique's destructor aborting, as a failed assertion
# does) is recorded as crashed at teardown, not at a frame past the last; its console line and its
# report row show where the log is and the log's last lines.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/teardown.yaml"
cat > "$cfg" <<YAML
name: teardown
resolution: [64, 36]
frames: {warmup: 1, count: 3, metrics_every: 0}
scenes: [cornell-box]
plugin_dirs: [$TEST_PLUGINS]
techniques:
  - technique: crash_on_frame
    params: {crash_in_teardown: true}
  - technique: crash_on_frame
    params: {crash_frame: 2}
YAML
expect_exit 1 "a run with a crashed cell exits 1" -- "$PB" run "$cfg" --out "$WORK/run"
console="$OUT"
# record PARAM VALUE FIELD: FIELD of the cell whose params set PARAM to VALUE.
record() {
  /usr/bin/python3 - "$WORK/run/cells" "$@" <<'PY'
import glob, json, os, sys
cells, param, value, field = sys.argv[1:]
for path in glob.glob(os.path.join(cells, "*", "cell.json")):
    d = json.load(open(path))
    if d["params"].get(param) == value:
        print(d.get(field))
PY
}
expect_match "the teardown crash is said to be at teardown" \
  "^crashed with signal 6 \(Aborted\) during teardown, after its last frame$" \
  "$(record crash_in_teardown true reason)"
expect_match "a teardown crash has no failed frame" "^None$" "$(record crash_in_teardown true failed_frame)"
expect_match "a crash mid-run still names its frame" "^crashed with signal 11 \(Segmentation fault\) at frame 2$" \
  "$(record crash_frame 2 reason)"
expect_match "the console line says where the crash was" \
  "crash_on_frame__.*: FAILED: crashed with signal 6 \(Aborted\) during teardown" "$console"
expect_match "the console names the cell's log" "logs/cornell-box__crash_on_frame__.*\.log ends:" "$console"
expect_match "the console shows the log's last lines" "\| test: assertion failed in ~CrashOnFrame" "$console"
expect_exit 0 "the report is written" -- "$PB" report "$WORK/run"
expect_match "the report's failed row shows the log's last lines" \
  "test: assertion failed in ~CrashOnFrame" "$(cat "$WORK/run/report/index.html")"
finish
