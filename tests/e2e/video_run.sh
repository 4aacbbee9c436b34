# `video:` end to end: a run saves every second measured frame of the chosen technique's cells (and
# none of the others', none of the warm-up), `photonbench video` encodes them, and ffprobe reads the
# WebM (VP9, size, frame count) and the lossless animated crop. Without ffmpeg it exits 77 (skipped).
source "$(dirname "$0")/lib.bash"
if ! command -v ffmpeg > /dev/null || ! command -v ffprobe > /dev/null; then
  echo "skipped: ffmpeg/ffprobe not installed (scripts/setup.sh installs ffmpeg)"
  exit 77
fi
cfg="$WORK/video.yaml"
cat > "$cfg" <<YAML
name: video
resolution: [48, 28]
frames: {warmup: 2, count: 7, metrics_every: 0}
scenes: [cornell-box]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 128]}
  - technique: tiled
    params: {photons: 2000, shadow_map_size: 64}
video: {every: 2, cells: [direct], crop: [8, 4, 16, 10]}
YAML
run="$WORK/run"
expect_exit 0 "run with video:" -- "$PB" run "$cfg" --out "$run"
for cell in "$run"/cells/*__direct__*; do
  expect_match "direct saved measured frames 2, 4, 6, 8" '^frame_0002.png frame_0004.png frame_0006.png frame_0008.png video.json $' \
    "$(ls "$cell/video" | tr '\n' ' ')"
done
tiled=$(ls -d "$run"/cells/*__tiled__*)
[ -e "$tiled/video" ] && fail "tiled is not in video.cells but has a video folder" || pass "tiled not captured"
expect_exit 0 "photonbench video" -- "$PB" video "$run"
probe() { ffprobe -v error -count_frames -select_streams v:0 -show_entries \
  stream=codec_name,width,height,nb_read_frames,r_frame_rate -of csv=p=0 "$1"; }
for cell in "$run"/cells/*__direct__*; do
  id=$(basename "$cell")
  expect_match "$id: VP9, 48x28, 4 frames at 15 fps" '^vp9,48,28,15/1,4$' "$(probe "$run/videos/cornell-box/$id.webm")"
  expect_match "$id: animated PNG of the crop, 8x" '^apng,128,80,15/1,4$' "$(probe "$run/videos/cornell-box/${id}_crop.png")"
done
expect_match "side by side of the two direct cells, with labels" '^vp9,96,44,15/1,4$' \
  "$(probe "$run/videos/cornell-box/side_by_side.webm")"
expect_exit 0 "without ffmpeg: skipped, exit 0" -- env PATH=/nonexistent "$PB" video "$run"
expect_match "it says so" "ffmpeg is not on PATH" "$OUT"
finish
