# cell.json's memory after the first 100 frames (the long run's check that memory stays flat,
# configs/long-run.yaml): present with the run's peaks beside it once a cell has played 100 frames,
# null before.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/memory.yaml"
write_config "$cfg" "scenes: [cornell-box]"
sed -i 's/count: 1,/count: 120,/' "$cfg"
expect_exit 0 "a 120-frame cell runs" -- "$PB" run "$cfg" --out "$WORK/long"
expect_exit 0 "first_100_frames holds the early peaks, never above the run's" -- /usr/bin/python3 - "$WORK"/long/cells/*/cell.json <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))["memory"]
early = m["first_100_frames"]
assert early is not None, "no first_100_frames"
assert set(early) == {"frames", "peak_host_bytes", "host_bytes", "gpu_bytes_technique", "gpu_bytes_total"}, sorted(early)
assert early["frames"] == 100
for key in ("peak_host_bytes", "gpu_bytes_technique", "gpu_bytes_total"):
    assert 0 <= early[key] <= m[key], (key, early[key], m[key])
assert 0 < early["host_bytes"] <= early["peak_host_bytes"], (early["host_bytes"], early["peak_host_bytes"])
assert 0 < m["host_bytes_end"] <= m["peak_host_bytes"], (m["host_bytes_end"], m["peak_host_bytes"])
assert early["gpu_bytes_total"] > 0 and early["peak_host_bytes"] > 0
PY
sed -i 's/count: 120,/count: 99,/' "$cfg"
expect_exit 0 "a 99-frame cell runs" -- "$PB" run "$cfg" --out "$WORK/short"
expect_match "fewer than 100 frames: first_100_frames is null" "^None$" \
  "$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["memory"]["first_100_frames"])' "$WORK"/short/cells/*/cell.json)"
finish
