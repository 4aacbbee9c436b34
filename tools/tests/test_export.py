"""export --format github-action-benchmark: the JSON shape that tool reads, and the values."""

import csv
import io
import json
import math
import os
import unittest
from contextlib import redirect_stderr, redirect_stdout

from common import TempRuns

from pbtools import export as E


class ExportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", seed=3, images=False)
        out, err = io.StringIO(), io.StringIO()
        with redirect_stdout(out), redirect_stderr(err):
            cls.rc = E.main([cls.run_dir, "--format", "github-action-benchmark", "--out", cls.tmp.path("gab")])
        cls.stdout, cls.stderr = out.getvalue(), err.getvalue()
        with open(cls.tmp.path("gab", "customSmallerIsBetter.json")) as f:
            cls.smaller = json.load(f)
        with open(cls.tmp.path("gab", "customBiggerIsBetter.json")) as f:
            cls.bigger = json.load(f)
        with open(os.path.join(cls.run_dir, "summary.csv"), newline="") as f:
            cls.summary = list(csv.DictReader(f))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_shape(self):
        self.assertEqual(self.rc, 0)
        for data in (self.smaller, self.bigger):
            self.assertIsInstance(data, list)
            self.assertTrue(data)
            names = [e["name"] for e in data]
            self.assertEqual(len(names), len(set(names)), "names must be unique")
            for e in data:
                self.assertLessEqual(set(e), {"name", "unit", "value", "range", "extra"})
                self.assertIsInstance(e["name"], str)
                self.assertIsInstance(e["unit"], str)
                self.assertIsInstance(e["value"], (int, float))
                self.assertTrue(math.isfinite(e["value"]))
                for opt in ("range", "extra"):
                    if opt in e:
                        self.assertIsInstance(e[opt], str)

    def test_values_and_direction(self):
        smaller = {e["name"]: e for e in self.smaller}
        bigger = {e["name"]: e for e in self.bigger}
        ok = [r for r in self.summary if r["status"] == "ok"]
        for r in ok:
            frame = [e for n, e in smaller.items() if n.endswith("/frame") and f"cell {r['cell']};" in e["extra"]]
            self.assertEqual(len(frame), 1, r["cell"])
            self.assertEqual(frame[0]["unit"], "ms")
            self.assertAlmostEqual(frame[0]["value"], float(r["wall_ms_median"]))
            flip = [e for n, e in smaller.items() if n.endswith("/flip") and f"cell {r['cell']};" in e["extra"]]
            self.assertAlmostEqual(flip[0]["value"], float(r["flip_mean"]))
            for m in ("ssim", "psnr"):
                e = [e for n, e in bigger.items() if n.endswith(f"/{m}") and f"cell {r['cell']};" in e["extra"]]
                self.assertAlmostEqual(e[0]["value"], float(r[f"{m}_mean"]))
            for col, text in r.items():
                if col.startswith("pass.") and text:
                    name = col[len("pass."):-len(".ms_median")]
                    e = [e for n, e in smaller.items() if n.endswith(f"/pass {name}")
                         and f"cell {r['cell']};" in e["extra"]]
                    self.assertAlmostEqual(e[0]["value"], float(text))
        # Similarities never in the smaller-is-better file, and the reverse.
        self.assertFalse([n for n in smaller if n.endswith(("/ssim", "/psnr"))])
        self.assertFalse([n for n in bigger if not n.endswith(("/ssim", "/psnr"))])
        self.assertTrue([n for n in smaller if n.endswith("/relmse")])

    def test_failed_cells_left_out_and_named(self):
        failed = [r["cell"] for r in self.summary if r["status"] != "ok"]
        self.assertEqual(len(failed), 3)
        for cid in failed:
            self.assertFalse([e for e in self.smaller + self.bigger if f"cell {cid};" in e["extra"]])
            self.assertIn(cid, self.stderr)


if __name__ == "__main__":
    unittest.main()
