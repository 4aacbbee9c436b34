"""Shared test set-up: import paths for the tools and the fixture generator, and temporary runs."""

import os
import shutil
import sys
import tempfile

TESTS_DIR = os.path.dirname(os.path.abspath(__file__))
TOOLS_DIR = os.path.dirname(TESTS_DIR)
for p in (TOOLS_DIR, TESTS_DIR):
    if p not in sys.path:
        sys.path.insert(0, p)

import fixture  # noqa: E402


class TempRuns:
    """A temporary folder of fixture runs, removed at the end."""

    def __init__(self):
        self.dir = tempfile.mkdtemp(prefix="pbtools-test-")

    def make(self, name: str, **kw) -> str:
        return fixture.make_run(os.path.join(self.dir, name), **kw)

    def path(self, *parts) -> str:
        return os.path.join(self.dir, *parts)

    def cleanup(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)
