"""history marks an entry whose machine, driver or build type differs from the previous entry's: in
`history list`, in `append`'s and `plot`'s output, in environment.csv and as a line in the plot; an
unchanged environment, or a field an older entry did not record, is not marked."""

import csv
import io
import json
import os
import unittest
from contextlib import redirect_stdout

from common import TempRuns

from pbtools import environment
from pbtools import history as H

KW = dict(images=False, scenes=["pillars"], techniques=["direct"])


def set_run_json(run_dir: str, **fields) -> None:
    path = os.path.join(run_dir, "run.json")
    with open(path) as f:
        info = json.load(f)
    for key, value in fields.items():
        if value is None:
            info.pop(key, None)
        else:
            info[key] = value
    with open(path, "w") as f:
        json.dump(info, f)


class HistoryEnvironmentTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.path = cls.tmp.path("history.jsonl")
        # 0, 1: one machine and driver (0 does not record its build type, as older runs did not);
        # 2: a newer Mesa; 3: the same; 4: a Debug build on another CPU.
        edits = [dict(build_type=None), dict(build_type="Release"),
                 dict(build_type="Release", driver="llvmpipe Mesa 24.2.1 (LLVM 17.0.6)"),
                 dict(build_type="Release", driver="llvmpipe Mesa 24.2.1 (LLVM 17.0.6)"),
                 dict(build_type="Debug", driver="llvmpipe Mesa 24.2.1 (LLVM 17.0.6)", cpu="Intel Xeon")]
        cls.append_out = []
        for i, edit in enumerate(edits):
            run = cls.tmp.make(f"r{i}", seed=i, commit=f"{i + 1:040x}", **KW)
            set_run_json(run, **edit)
            out = io.StringIO()
            with redirect_stdout(out):
                assert H.main(["append", run, "--file", cls.path]) == 0
            cls.append_out.append(out.getvalue())

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_entries_record_their_environment(self):
        env = H.load(self.path)[4]["environment"]
        self.assertEqual(env["build"], "Debug")
        self.assertEqual(env["driver"], "llvmpipe Mesa 24.2.1 (LLVM 17.0.6)")
        self.assertTrue(env["machine"].startswith("Intel Xeon, "), env["machine"])
        self.assertIsNone(H.load(self.path)[0]["environment"]["build"])
        # llvmpipe's vector width is part of the machine.
        self.assertEqual(environment.of({"cpu": "AMD EPYC", "cpu_count": 2,
                                         "device": "llvmpipe (LLVM 15.0.6, 256 bits)"})["machine"],
                         "AMD EPYC, 2 CPUs, 256-bit vectors")

    def test_changes_are_marked_where_they_happen(self):
        changes = H.environment_changes(H.load(self.path))
        self.assertEqual(sorted(changes), [2, 4])
        self.assertEqual([c[0] for c in changes[2]], ["driver"])
        self.assertEqual([c[0] for c in changes[4]], ["machine", "build"])
        self.assertEqual(changes[4][1][1:], ("Release", "Debug"))
        # append says it too, for the entries that changed only
        self.assertEqual(["!" in out for out in self.append_out], [False, False, True, False, True])

    def test_list_marks_the_changed_entries(self):
        out = io.StringIO()
        with redirect_stdout(out):
            self.assertEqual(H.main(["list", "--file", self.path]), 0)
        lines = out.getvalue().splitlines()
        marks = [x.strip() for x in lines if x.strip().startswith("!")]
        self.assertEqual(len(marks), 2)
        self.assertIn("before entry 2: driver Mesa 22.3.6", marks[0])
        self.assertIn("-> llvmpipe Mesa 24.2.1 (LLVM 17.0.6)", marks[0])
        self.assertIn("before entry 4: machine ", marks[1])
        self.assertIn("build Release -> Debug", marks[1])
        # each mark stands right before its entry's line
        self.assertTrue(lines[lines.index(next(x for x in lines if "before entry 4" in x)) + 1].strip()
                        .startswith("4 "))

    def test_plot_draws_a_line_at_each_change(self):
        out_dir = self.tmp.path("plots")
        out = io.StringIO()
        with redirect_stdout(out):
            self.assertEqual(H.main(["plot", "--file", self.path, "--out", out_dir]), 0)
        self.assertEqual(sum(x.startswith("! ") for x in out.getvalue().splitlines()), 2)
        with open(os.path.join(out_dir, "environment.csv"), newline="") as f:
            rows = [(int(r["index"]), r["changed"]) for r in csv.DictReader(f)]
        self.assertEqual(rows, [(2, "driver"), (4, "machine"), (4, "build")])
        svg = [n for n in os.listdir(out_dir) if n.endswith(".svg")][0]
        with open(os.path.join(out_dir, svg), encoding="utf-8") as f:
            text = f.read()
        self.assertTrue('id="environment:2"' in text, "no line at entry 2")
        self.assertTrue('id="environment:4"' in text, "no line at entry 4")
        self.assertNotIn('id="environment:1"', text)
        self.assertNotIn('id="environment:3"', text)


if __name__ == "__main__":
    unittest.main()
