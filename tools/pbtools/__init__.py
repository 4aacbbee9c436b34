"""photonbench's report and regression tools: report, compare, history, export.

Run through the photonbench executable (`photonbench report RUN_DIR`, ...), which executes
tools/pbtool.py with Debian's /usr/bin/python3, or directly: `/usr/bin/python3 tools/pbtool.py report RUN_DIR`.
"""
