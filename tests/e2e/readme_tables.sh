# Every technique README's Parameters, Counters and Budget knobs tables are generated from its
# descriptor, between marker comments (`photonbench docs technique NAME --write README.md`): each
# README is regenerated here from the built plugin and must equal the committed text, every column
# (docs and units included), so that a table cannot drift from the code.
source "$(dirname "$0")/lib.bash"
checked=0
for readme in "$SRC"/techniques/*/README.md; do
  name="$(basename "$(dirname "$readme")")"
  cp "$readme" "$WORK/README.md"
  if ! "$PB" docs technique "$name" --write "$WORK/README.md" > "$WORK/out.txt" 2>&1; then
    fail "$name: photonbench docs technique $name failed: $(cat "$WORK/out.txt")"
  elif diff -u "$readme" "$WORK/README.md" > "$WORK/diff.txt"; then
    pass "techniques/$name/README.md: its tables are its descriptor's"
  else
    fail "techniques/$name/README.md: its tables differ from its descriptor's (below); regenerate them with
  build/photonbench docs technique $name --write techniques/$name/README.md
$(cat "$WORK/diff.txt")"
  fi
  checked=$((checked + 1))
done
[ "$checked" -gt 0 ] && pass "$checked technique READMEs checked" || fail "no technique README found"
# A README without the markers is refused, naming the file and the missing marker.
printf '# t\n\n## Parameters\n\n| name |\n|---|\n' > "$WORK/bare.md"
expect_exit 2 "a README without markers is refused" -- "$PB" docs technique direct --write "$WORK/bare.md"
expect_match "the refusal names the file and the marker" "bare.md: no '<!-- generated: parameters -->' marker" "$OUT"
finish
