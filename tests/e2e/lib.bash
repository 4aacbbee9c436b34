# Shared by the end-to-end tests: $1 is the photonbench executable, $2 the source tree.
set -u
PB="$(realpath "$1")"
SRC="$(realpath "$2")"
TEST_PLUGINS="$(dirname "$PB")/test-plugins"
# Set when $PB is the sanitized build (scripts/test.sh --sanitize), whose executables need the
# AddressSanitizer runtime: a script may take a smaller size there where its check does not depend
# on the size, saying why where it does so.
SANITIZED=""
readelf -d "$PB" | grep -q 'NEEDED.*libasan' && SANITIZED=1
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
failures=0
passes=0

fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok: $*"; passes=$((passes + 1)); }

# expect_exit CODE NAME -- command...: runs it, keeps its output in $OUT, checks the exit code.
expect_exit() {
  local code="$1" name="$2"
  shift 3
  OUT="$("$@" 2>&1)"
  local got=$?
  if [ "$got" -eq "$code" ]; then pass "$name (exit $got)"; else fail "$name: exit $got, expected $code; output: $OUT"; fi
}

# expect_match NAME REGEX TEXT
expect_match() {
  if printf '%s\n' "$3" | grep -Eq -- "$2"; then pass "$1"; else fail "$1: no match for /$2/ in: $3"; fi
}

json_field() { /usr/bin/python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(d.get(sys.argv[2]))" "$1" "$2"; }

# A config for the bad-input tests: one small direct cell, no metric frames (no reference), plus
# any extra lines. write_config FILE [LINE...]
write_config() {
  local file="$1"
  shift
  printf '%s\n' "name: t" "resolution: [64, 36]" "frames: {warmup: 0, count: 1, metrics_every: 0}" \
    "techniques:" "  - technique: direct" "$@" > "$file"
}

finish() {
  echo "$passes passed, $failures failed"
  [ "$failures" -eq 0 ]
}

# expect_no_match NAME REGEX TEXT
expect_no_match() {
  if printf '%s\n' "$3" | grep -Eq -- "$2"; then fail "$1: /$2/ matched in: $3"; else pass "$1"; fi
}
