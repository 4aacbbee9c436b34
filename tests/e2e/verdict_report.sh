# The report's verdict per scene on a real run: two settings whose scores lie within their noise
# floors are ordered with ≈, not <, with what would resolve them, and no score of the scene is bold
# as its best; run.json carries the harness's resolve factor, the one the tools read scores with.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/verdict.yaml"
cat > "$cfg" <<YAML
name: verdict
resolution: [64, 36]
frames: {warmup: 0, count: 2, metrics_every: 1}
reference: {samples: 4, cache_dir: $WORK/cache}
scenes: [cornell-box]
techniques:
  - technique: direct
    params: {shadow_map_size: [256, 512]}
YAML
expect_exit 0 "the run completes" -- "$PB" run "$cfg" --out "$WORK/run"
expect_exit 0 "the report is written" -- "$PB" report "$WORK/run"
html=$(cat "$WORK/run/report/index.html")
expect_match "the report has a verdict section" '<h2 id="verdict">Verdict</h2>' "$html"
# Two shadow-map sizes of one technique against a 4-sample reference: their gap is far inside the
# floors.
expect_match "the unresolved order is ≈" "<h3>cornell-box: direct \(shadow_map_size=[0-9]+\) ≈ direct" "$html"
expect_match "it says what would resolve it" "reference.rel_error &lt;= |floors summing under the gap|nothing: the scores are equal" "$html"
expect_match "no resolved best" "No resolved best" "$html"
expect_no_match "no FLIP or SSIM score (4 decimals) is bold" '<b>[0-9]+\.[0-9]{4}</b>' "$html"
factor=$(json_field "$WORK/run/run.json" resolve_factor)
tools_factor=$(cd "$SRC/tools" && /usr/bin/python3 -c "from pbtools import floors; print(floors.RESOLVE_FACTOR)")
expect_match "run.json's resolve factor is the tools' ($tools_factor)" "^$tools_factor$" "$factor"
finish
