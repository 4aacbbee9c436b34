# Budget knobs end to end: `list techniques` prints each technique's, the first as the default
# knob (each README's table is generated from the descriptor: readme_tables.sh).
source "$(dirname "$0")/lib.bash"
expect_exit 0 "list techniques" -- "$PB" list techniques
expect_match "tiled's knobs are listed, the first the default" \
  "^  photons +cost grows +error falls +log scale +\(the default knob\)" "$OUT"
expect_match "AAPS's target area costs less as it grows" "^  target_area +cost falls +error grows +log scale" "$OUT"
finish
