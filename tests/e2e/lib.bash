# Shared by the end-to-end tests: $1 is the photonbench executable, $2 the source tree.
set -u
PB="$(realpath "$1")"
SRC="$(realpath "$2")"
TEST_PLUGINS="$(dirname "$PB")/test-plugins"
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

finish() {
  echo "$passes passed, $failures failed"
  [ "$failures" -eq 0 ]
}
