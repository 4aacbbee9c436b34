# Each technique README's parameter table is its schema's (names, types, defaults and ranges) and
# its counter table the counters its descriptor declares (names, kinds, units) (readme_params.py),
# so a README copied by hand cannot drift from the descriptor.
source "$(dirname "$0")/lib.bash"
"$PB" schema config > "$WORK/schema.json" && pass "photonbench schema config" || fail "schema config failed"
expect_exit 0 "every README's parameter and counter tables match the descriptors" -- \
  /usr/bin/python3 "$SRC/tests/e2e/readme_params.py" "$WORK/schema.json" "$SRC"
printf '%s\n' "$OUT"
finish
