# Budget knobs end to end: `list techniques` prints each technique's, and each technique README's
# "## Budget knobs" table equals what its descriptor declares (`photonbench schema config`,
# "x-budget": name, cost and error directions, scale; none for a technique that says "None").
source "$(dirname "$0")/lib.bash"
expect_exit 0 "list techniques" -- "$PB" list techniques
expect_match "tiled's knobs are listed, the first the default" \
  "^  photons +cost grows +error falls +log scale +\(the default knob\)" "$OUT"
expect_match "AAPS's target area costs less as it grows" "^  target_area +cost falls +error grows +log scale" "$OUT"
"$PB" schema config > "$WORK/schema.json" 2>/dev/null || fail "schema config"
expect_exit 0 "every README's budget-knob table is its descriptor's" -- /usr/bin/python3 - "$WORK/schema.json" "$SRC" <<'PY'
import json, pathlib, sys
schema, src = json.load(open(sys.argv[1])), pathlib.Path(sys.argv[2])
problems, checked = [], 0
for entry in schema["$defs"]["config.technique"]["anyOf"]:
    technique = entry["properties"]["technique"]
    name, declared = technique["const"], technique.get("x-budget", {})
    readme = src / "techniques" / name / "README.md"
    if not readme.exists():
        continue
    lines = readme.read_text().splitlines()
    start = next((i for i, l in enumerate(lines) if l.startswith("## Budget knobs")), None)
    if start is None:
        problems.append(f"{name}: no '## Budget knobs' section")
        continue
    rows = {}
    for line in lines[start + 1:]:
        if line.startswith("## "):
            break
        cells = [c.strip().strip("`") for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] not in ("knob", "---"):
            rows[cells[0]] = {"cost": cells[1], "error": cells[2], "scale": cells[3]}
    if not declared and not rows and "None" not in "\n".join(lines[start:start + 3]):
        problems.append(f"{name}: declares no budget knob and its README does not say None")
    for knob in sorted(set(declared) | set(rows)):
        if declared.get(knob) != {k: rows.get(knob, {}).get(k) for k in ("cost", "error", "scale")}:
            problems.append(f"{name}.{knob}: descriptor {declared.get(knob)}, README {rows.get(knob)}")
    checked += 1
print("\n".join(problems))
sys.exit(1 if problems or checked < 6 else 0)
PY
finish
