#!/usr/bin/env bash
# Checks the formatting of the C++ and GLSL sources: `clang-format --dry-run -Werror` with the
# repository's .clang-format (Debian's clang-format, installed by scripts/setup.sh), and no line over
# 100 columns (clang-format leaves comments as written, ReflowComments: false, so long comment lines
# are caught here). Exits 1 naming each file and line that is off.
#
#   scripts/check_format.sh [--fix] [PATH...]   (default: every C++ and GLSL source)
#
# --fix rewrites the files with clang-format -i instead (long comment lines stay for you to wrap).
set -euo pipefail
cd "$(dirname "$0")/.."

fix=0
if [[ "${1:-}" == "--fix" ]]; then fix=1; shift; fi
paths=("$@")
exclude='^$'
if ((${#paths[@]} == 0)); then
  # Every C++ and GLSL source of the repository.
  paths=(harness techniques tests bench examples)
fi

mapfile -t files < <(git ls-files --cached --others --exclude-standard -- "${paths[@]}" |
  grep -E '\.(cpp|h|comp|vert|frag|glsl)$' | grep -Ev "$exclude" | sort -u)
if ((${#files[@]} == 0)); then
  echo "check_format: no C++ or GLSL files under ${paths[*]}" >&2
  exit 2
fi
command -v clang-format > /dev/null || { echo "check_format: clang-format missing (scripts/setup.sh)" >&2; exit 2; }

if ((fix)); then
  clang-format -i "${files[@]}"
  echo "check_format: formatted ${#files[@]} files"
  exit 0
fi
status=0
clang-format --dry-run -Werror "${files[@]}" || status=1
python3 - "${files[@]}" <<'PY' || status=1
import sys
bad = 0
for name in sys.argv[1:]:
    with open(name, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            width = len(line.rstrip("\n"))
            if width > 100:
                print(f"{name}:{number}: {width} columns (at most 100)")
                bad = 1
sys.exit(bad)
PY
if ((status)); then
  echo "check_format: not formatted (scripts/check_format.sh --fix, then wrap long comments)" >&2
else
  echo "check_format: ${#files[@]} files formatted"
fi
exit $status
