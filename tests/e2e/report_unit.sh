#!/usr/bin/env bash
# The report tools' Python unit tests (tools/tests): figure data against its CSV, compare on A/A and
# slowed fixture runs, export JSON shape, history change points, report files and tables, measures.py.
# Args: $1 photonbench executable (unused: these test the Python directly), $2 source dir.
set -uo pipefail
src="${2:?usage: report_unit.sh PHOTONBENCH SOURCE_DIR}"
# Debian's interpreter: it has python3-pandas/-scipy/-numpy/-matplotlib/-jinja2 (scripts/setup.sh).
cd "$src/tools/tests" || exit 1
MPLBACKEND=Agg /usr/bin/python3 -m unittest discover -s "$src/tools/tests" -t "$src/tools/tests"
