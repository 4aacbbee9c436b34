#!/usr/bin/python3
"""Entry point of photonbench's Python tools: pbtool.py {report,compare,history,export,claims,video,scaling} ARGS...

The photonbench executable's sub-commands of the same names run this file with /usr/bin/python3
(Debian's interpreter, which has python3-pandas, -scipy, -numpy, -matplotlib and -jinja2) and forward
its exit code.
Exit codes follow photonbench's: 0 success, 1 failed work (compare: a significant regression), 2 bad input.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

COMMANDS = {
    "report": "pbtools.report",
    "compare": "pbtools.compare",
    "history": "pbtools.history",
    "export": "pbtools.export",
    "claims": "pbtools.claims",
    "video": "pbtools.video",
    "scaling": "pbtools.scaling",
}


def main() -> int:
    if len(sys.argv) < 2 or sys.argv[1] not in COMMANDS:
        print(f"usage: pbtool.py {{{','.join(COMMANDS)}}} [ARGS...]", file=sys.stderr)
        return 2
    import importlib
    module = importlib.import_module(COMMANDS[sys.argv[1]])
    try:
        return module.main(sys.argv[2:])
    except BrokenPipeError:  # output piped into `head`: not an error of the tool
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
