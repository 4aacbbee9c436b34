# `photonbench metrics` on its own: JSON output on a conformance pair, an error map, and exit 2 on bad input.
source "$(dirname "$0")/lib.bash"
data="$SRC/tests/data/metrics"
expect_exit 0 "metrics --json on an LDR pair" -- "$PB" metrics --reference "$data/ldr01_ref.png" --test "$data/ldr01_test.png" --json --error-map "$WORK/err.png"
expect_match "JSON has every documented key" '"flip":\{"mean":.*"weighted_median".*"q1".*"q3".*"min".*"max".*\},"ssim":.*"psnr":.*"identical":false,"rmse":.*"mae":.*"relmse"' "$(printf '%s' "$OUT" | tr -d ' \n')"
expected=$(/usr/bin/python3 -c "import json; d=json.load(open('$data/expected.json')); c=[c for c in d['cases'] if c['test'].startswith('ldr01')][0] if isinstance(d,dict) and 'cases' in d else None; print('' if c is None else round(c['flip']['mean'],4))" 2>/dev/null)
got=$(printf '%s' "$OUT" | /usr/bin/python3 -c "import json,sys; print(round(json.load(sys.stdin)['flip']['mean'],4))")
[ -z "$expected" ] || { [ "$got" = "$expected" ] && pass "FLIP mean matches expected.json ($got)" || fail "FLIP mean $got, expected $expected"; }
[ -s "$WORK/err.png" ] && pass "error map written" || fail "no error map"
expect_exit 0 "identical images" -- "$PB" metrics --reference "$data/ldr01_ref.png" --test "$data/ldr01_ref.png" --json
expect_match "identical images give psnr null" '"psnr":null' "$(printf '%s' "$OUT" | tr -d ' \n')"
expect_exit 2 "a missing file is bad input" -- "$PB" metrics --reference "$WORK/none.png" --test "$data/ldr01_test.png"
expect_exit 2 "an LDR/HDR mix is bad input" -- "$PB" metrics --reference "$data/ldr01_ref.png" --test "$data/hdr01_test.exr"
finish
