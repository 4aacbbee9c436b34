"""The fixture follows the results schema (docs/architecture.md) exactly, and the reader tolerates what failed or
interrupted cells leave behind."""

import csv
import json
import math
import os
import re
import struct
import unittest

from common import TempRuns

from pbtools.rundata import Run, RunError

SUMMARY_FIXED = ["cell", "scene", "technique", "status", "frames", "frame_ms_median", "frame_ms_p5",
                 "frame_ms_p95", "flip_mean", "ssim_mean", "psnr_mean", "flip_floor", "ssim_floor", "psnr_floor"]


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
        self.assertTrue(math.isnan(broken.value("frame_ms_median")))
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


if __name__ == "__main__":
    unittest.main()
