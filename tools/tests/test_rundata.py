"""The fixture follows the results schema (docs/architecture.md) exactly, and the reader tolerates what failed or
interrupted cells leave behind."""

import csv
import io
import json
import math
import os
import re
import shutil
import struct
import unittest
from contextlib import redirect_stderr, redirect_stdout

from common import TempRuns

from pbtools.rundata import Run, RunError

SUMMARY_FIXED = ["cell", "scene", "technique", "status", "frames", "wall_ms_median", "wall_ms_p5",
                 "wall_ms_p95", "flip_mean", "ssim_mean", "psnr_mean", "flip_floor", "ssim_floor", "psnr_floor"]


def header(path):
    with open(path, newline="") as f:
        return next(csv.reader(f))


class SchemaTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", seed=1)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_files_and_columns(self):
        cols = header(os.path.join(self.run_dir, "summary.csv"))
        self.assertEqual(cols[:len(SUMMARY_FIXED)], SUMMARY_FIXED)
        for c in cols[len(SUMMARY_FIXED):]:
            self.assertRegex(c, r"^(param\.[\w-]+|pass\.[\w/-]+\.ms_median)$")
        self.assertIn("pass.splat/sort.ms_median", cols)
        with open(os.path.join(self.run_dir, "run.json")) as f:
            info = json.load(f)
        for key in ("tool_version", "git_commit", "config", "config_hash", "device", "driver", "cpu", "os",
                    "start", "end"):
            self.assertIn(key, info)
        for cell in os.listdir(os.path.join(self.run_dir, "cells")):
            d = os.path.join(self.run_dir, "cells", cell)
            with open(os.path.join(d, "cell.json")) as f:
                cj = json.load(f)
            self.assertIn(cj["status"], ("ok", "failed"))
            for key in ("reason", "failed_frame", "warnings", "params"):
                self.assertIn(key, cj)
            if not os.path.exists(os.path.join(d, "frames.csv")):
                self.assertEqual(cj["status"], "failed")
                continue
            self.assertEqual(header(os.path.join(d, "frames.csv")), ["frame", "pass", "gpu_ms", "cpu_ms"])
            self.assertEqual(header(os.path.join(d, "counters.csv")), ["frame", "name", "value"])
            self.assertEqual(header(os.path.join(d, "metrics.csv")),
                             ["frame", "path_class", "reference", "flip", "ssim", "psnr", "rmse", "relmse",
                              "flip_floor", "ssim_floor", "psnr_floor", "rmse_floor", "relmse_floor",
                              "mse_unbiased", "relmse_unbiased"])
            with open(os.path.join(d, "frames.csv"), newline="") as f:
                self.assertIn("frame", {r["pass"] for r in csv.DictReader(f)})
            for name in os.listdir(os.path.join(d, "images")):
                self.assertRegex(name, r"^(frame_\d{4}\.(exr|png)|(flip|reference)_\d{4}_[\w-]+\.png)$")

    def test_exr_is_valid_openexr(self):
        d = os.path.join(self.run_dir, "cells", "000-cornell-box-direct", "images")
        with open(os.path.join(d, "frame_0008.exr"), "rb") as f:
            data = f.read()
        magic, version = struct.unpack("<ii", data[:8])
        self.assertEqual(magic, 20000630)
        self.assertEqual(version, 2)
        # Walk the header's attributes (name\0 type\0 size value) to its terminating \0.
        pos, attrs = 8, {}
        while data[pos] != 0:
            name_end = data.index(b"\0", pos)
            type_end = data.index(b"\0", name_end + 1)
            (size,) = struct.unpack("<i", data[type_end + 1:type_end + 5])
            attrs[data[pos:name_end].decode()] = data[type_end + 5:type_end + 5 + size]
            pos = type_end + 5 + size
        pos += 1
        self.assertEqual(struct.unpack("<iiii", attrs["dataWindow"]), (0, 0, 95, 53))
        self.assertEqual(attrs["compression"], b"\0")
        # Line offset table, then 54 scanlines of (y, size, B G R floats).
        offsets = struct.unpack("<54Q", data[pos:pos + 8 * 54])
        self.assertEqual(offsets[0], pos + 8 * 54)
        self.assertEqual(len(data), offsets[0] + 54 * (8 + 96 * 3 * 4))
        self.assertEqual(struct.unpack("<ii", data[offsets[7]:offsets[7] + 8]), (7, 96 * 3 * 4))


class ReaderTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", seed=2, images=False)
        cls.rd = Run(cls.run_dir)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_cells_params_passes(self):
        self.assertEqual(len(self.rd.cells), 16)
        self.assertEqual(self.rd.scenes(), ["cornell-box", "pillars"])
        self.assertEqual(self.rd.techniques(), ["direct", "tiled", "cluster", "broken"])
        c = self.rd.cell("002-cornell-box-tiled-photons=100000-radius=0.05")
        self.assertEqual(c.params, {"photons": 100000, "radius": 0.05})
        self.assertEqual(self.rd.label(c), "tiled (photons=100000)")  # radius is not swept
        self.assertIn("splat/sort", c.pass_medians())
        frames, ms = c.pass_samples("trace")  # CPU-only pass: gpu_ms empty, cpu_ms used
        self.assertEqual(len(frames), 24)
        with open(os.path.join(c.dir, "frames.csv"), newline="") as f:
            cpu = [float(r["cpu_ms"]) for r in csv.DictReader(f) if r["pass"] == "trace"]
        self.assertEqual(list(ms), cpu)
        self.assertEqual(self.rd.commit, self.rd.info["git_commit"])

    def test_failed_cells(self):
        broken = self.rd.cell("007-cornell-box-broken")
        self.assertFalse(broken.ok)
        self.assertIsNone(broken.failed_frame)
        self.assertEqual(broken.pass_names(), [])
        self.assertTrue(math.isnan(broken.value("wall_ms_median")))
        trivial = self.rd.cell("014-pillars-cluster-variant=trivial")
        self.assertEqual(trivial.failed_frame, 13)
        self.assertEqual(len(trivial.pass_samples("frame")[0]), 13)

    def test_warning_forms(self):
        c = self.rd.cell("000-cornell-box-direct")
        c._json = {"warnings": [{"frame": 3, "message": "a"}, [4, "b"], "plain text"]}
        self.assertEqual(c.warnings, [{"frame": 3, "message": "a"}, {"frame": 4, "message": "b"},
                                      {"frame": None, "message": "plain text"}])

    def test_not_a_run(self):
        with self.assertRaises(RunError):
            Run(self.tmp.path("nothing"))
        os.makedirs(self.tmp.path("empty"))
        with self.assertRaises(RunError):
            Run(self.tmp.path("empty"))


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


class HandMadeRunTest(unittest.TestCase):
    """What pandas makes of a run a failed or interrupted sweep leaves behind: columns the summary
    lacks, empty and unparsable fields, a failed cell with no files, a frames.csv without cpu_ms, a
    metrics.csv from before the reference column, an empty counters.csv; and names pandas would take
    for missing values ("nan", "NA", "null") staying names."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = root = cls.tmp.path("hand")
        write(os.path.join(root, "run.json"), '{"git_commit": "abc", "device": "test"}')
        write(os.path.join(root, "summary.csv"),
              "cell,scene,technique,status,frames,wall_ms_median,flip_mean,param.photons,"
              "param.variant,pass.splat.ms_median\n"
              "c-ok,nan,NA,ok,3,2.5,,100000,,1.25\n"
              "c-failed,nan,null,failed,0,,n/a,1e5,plain,\n"
              "c-box,box,direct,ok,2,3.0,0.2,,,\n")
        cells = os.path.join(root, "cells")
        write(os.path.join(cells, "c-ok", "cell.json"), '{"status": "ok"}')
        # No cpu_ms column; one splat time missing.
        write(os.path.join(cells, "c-ok", "frames.csv"),
              "frame,pass,gpu_ms\n2,splat,1.5\n0,splat,1.0\n1,splat,\n"
              "0,frame,2.0\n1,frame,2.5\n2,frame,3.0\n")
        # No reference column (a run from before it): scored against the full reference.
        write(os.path.join(cells, "c-ok", "metrics.csv"),
              "frame,path_class,flip,ssim\n0,combined,0.3,\n2,combined,0.1,0.9\n")
        write(os.path.join(cells, "c-ok", "counters.csv"), "")
        write(os.path.join(cells, "c-failed", "cell.json"),
              '{"status": "failed", "reason": "plugin did not load", "failed_frame": null}')
        write(os.path.join(cells, "c-box", "cell.json"), '{"status": "ok"}')
        write(os.path.join(cells, "c-box", "frames.csv"),
              "frame,pass,gpu_ms,cpu_ms\n0,frame,3.0,3.1\n")
        write(os.path.join(cells, "c-box", "metrics.csv"), "frame,path_class,reference,flip\n")
        cls.rd = Run(root)
        cls.ok, cls.failed, cls.box = (cls.rd.cell(c) for c in ("c-ok", "c-failed", "c-box"))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_names_stay_text(self):
        self.assertEqual(self.rd.scenes(), ["nan", "box"])
        self.assertEqual(self.rd.techniques(), ["NA", "null", "direct"])
        self.assertEqual([c.status for c in self.rd.cells], ["ok", "failed", "ok"])

    def test_params_keep_the_type_they_were_written_in(self):
        self.assertEqual(self.ok.params, {"photons": 100000})
        self.assertIsInstance(self.ok.params["photons"], int)
        self.assertEqual(self.failed.params, {"photons": 100000.0, "variant": "plain"})
        self.assertIsInstance(self.failed.params["photons"], float)
        self.assertEqual(self.box.params, {})
        self.assertEqual(self.rd.label(self.ok), "NA")  # one cell of its technique: nothing swept

    def test_missing_empty_and_unparsable_fields_are_nan(self):
        self.assertEqual(self.ok.value("frames"), 3.0)
        for cell in (self.ok, self.failed):
            self.assertTrue(math.isnan(cell.value("flip_mean")))  # empty, "n/a"
            self.assertTrue(math.isnan(cell.value("ssim_mean")))  # no such column
        self.assertEqual(self.box.value("flip_mean"), 0.2)
        self.assertEqual(self.ok.pass_medians(), {"splat": 1.25})
        self.assertEqual(self.failed.pass_medians(), {})
        self.assertEqual(self.ok.text("frames"), "3")

    def test_per_cell_files_with_missing_columns(self):
        frames, ms = self.ok.pass_samples("splat")
        # Sorted by frame; the empty time dropped.
        self.assertEqual((list(frames), list(ms)), ([0, 2], [1.0, 1.5]))
        self.assertEqual(len(self.ok.pass_samples("splat", "cpu")[0]), 0)  # the file has no cpu_ms
        self.assertEqual(self.ok.metric_references(), ["full"])
        self.assertEqual([list(a) for a in self.ok.metric_series("flip")], [[0, 2], [0.3, 0.1]])
        self.assertEqual(self.ok.metric_mean("ssim"), 0.9)
        self.assertTrue(math.isnan(self.ok.metric_mean("psnr")))
        self.assertEqual(len(self.ok.counter_means()), 0)  # empty counters.csv
        # The failed cell has no files at all: empty tables with the schema's columns.
        self.assertEqual(self.failed.pass_names(), [])
        self.assertEqual(list(self.failed.frames.columns), ["frame", "pass", "gpu_ms", "cpu_ms"])
        self.assertIsNone(self.failed.primary_class())
        self.assertEqual(self.failed.reason, "plugin did not load")
        self.assertEqual(self.box.metric_classes(), [])  # header only

    def test_tools_run_on_it(self):
        from pbtools import compare, export, report
        out = io.StringIO()
        with redirect_stdout(out), redirect_stderr(io.StringIO()):
            self.assertEqual(report.main([self.run_dir, "--out", self.tmp.path("hand-report")]), 0)
            self.assertEqual(compare.main([self.run_dir, self.run_dir]), 0)
            self.assertEqual(export.main([self.run_dir, "--format", "github-action-benchmark",
                                          "--out", self.tmp.path("hand-export")]), 0)
        with open(self.tmp.path("hand-report", "tables", "summary.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([(r["scene"], r["technique"], r["status"]) for r in rows],
                         [("nan", "NA", "ok"), ("nan", "null", "failed"), ("box", "direct", "ok")])
        self.assertEqual(rows[1]["reason"], "plugin did not load")

    def test_a_row_longer_than_its_header_is_bad_input_naming_file_and_line(self):
        bad = self.tmp.path("bad")
        shutil.copytree(self.run_dir, bad)
        path = os.path.join(bad, "cells", "c-box", "frames.csv")
        write(path, "frame,pass,gpu_ms,cpu_ms\n0,frame,3.0,3.1\n1,frame,3.0,3.1,9\n")
        with self.assertRaises(RunError) as e:
            Run(bad).cell("c-box").frames
        self.assertIn(path, str(e.exception))
        self.assertIn("line 3", str(e.exception))
        from pbtools import report
        err = io.StringIO()
        with redirect_stdout(io.StringIO()), redirect_stderr(err):
            self.assertEqual(report.main([bad]), 2)
        self.assertIn(path, err.getvalue())


if __name__ == "__main__":
    unittest.main()
