# A technique that segfaults, throws, outputs NaN, hangs past the time limit or cannot be loaded fails
# only its own cell, with the reason and the frame; the cells after it still run.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/isolation.yaml"
cat > "$cfg" <<YAML
name: isolation
resolution: [64, 36]
frames: {warmup: 0, count: 4, metrics_every: 0}
scenes: [cornell-box]
plugin_dirs: [$TEST_PLUGINS]
limits: {cell_seconds: 20}  # generous: a loaded CI machine needs seconds just to start a cell
techniques:
  - technique: crash_on_frame
    params: {crash_frame: 1}
  - technique: throws_on_frame
    params: {throw_frame: 2}
  - technique: nan_output
    params: {nan_frame: 3}
  - technique: sleeps
    params: {sleep_ms: 10000}
  - technique: not_a_module
  - technique: direct
    params: {shadow_map_size: 256}
YAML
# Validation as CTest asks (PB_VALIDATION, tests/CMakeLists.txt: PB_TEST_VALIDATION).
validation=${PB_VALIDATION:+true}
expect_exit 1 "a run with failed cells exits 1" -- "$PB" run "$cfg" --out "$WORK/run" \
  ${validation:+--validation}
cells="$WORK/run/cells"
check() {  # technique, status, reason regex, failed frame
  local file
  file=$(ls "$cells"/cornell-box__"$1"__*/cell.json 2>/dev/null | head -1)
  if [ -z "$file" ]; then fail "$1: no cell.json"; return; fi
  local status reason frame
  status=$(json_field "$file" status); reason=$(json_field "$file" reason); frame=$(json_field "$file" failed_frame)
  [ "$status" = "$2" ] && pass "$1 status $status" || fail "$1: status $status, expected $2"
  expect_match "$1 reason" "$3" "$reason"
  [ "$frame" = "$4" ] && pass "$1 failed_frame $frame" || fail "$1: failed_frame $frame, expected $4"
}
check crash_on_frame failed "crashed with signal 11 \(Segmentation fault\) at frame 1" 1
check throws_on_frame failed "technique error at frame 2: splat list overflowed \(test\)" 2
check nan_output failed "output image holds [0-9]+ NaN or Inf values" 3
check sleeps failed "exceeded limits.cell_seconds = 20 s at frame [0-9]" "$(json_field "$(ls "$cells"/cornell-box__sleeps__*/cell.json)" failed_frame)"
check not_a_module failed "failed to load: dlopen failed: .*not_a_module.so" None
check direct ok "^$" None
crash_frames=$(ls "$cells"/cornell-box__crash_on_frame__*/frames.csv)
expect_match "the crashed cell keeps the frame it finished" "^0,frame," "$(cat "$crash_frames")"
expect_match "summary lists all six cells" "^6$" "$(($(wc -l < "$WORK/run/summary.csv") - 1))"
expect_match "the direct cell ran (without a validation error) and its record says validation ${validation:-false}" \
  "\"validation\": ${validation:-false}" "$(cat "$cells"/cornell-box__direct__*/cell.json)"
# The technique's GPU memory is a share of the total. direct's smaller shadow map frees more of the
# harness's memory than the technique allocates: the difference once wrapped to 1.8e19 bytes.
memory=$(python3 -c 'import json, sys; m = json.load(open(sys.argv[1]))["memory"]
print("yes" if 0 <= m["gpu_bytes_technique"] <= m["gpu_bytes_total"] else m)' "$(ls "$cells"/cornell-box__direct__*/cell.json)")
expect_match "the direct cell's technique memory is within the total" "^yes$" "$memory"
finish
