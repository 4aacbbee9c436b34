"""report: every file the page names exists under report/, nothing external is referenced, every figure
is written as SVG, PDF and PNG with its data, and the tables keep failed cells."""

import collections
import csv
import io
import json
import os
import re
import unittest
from contextlib import redirect_stdout
from html.parser import HTMLParser

from common import TempRuns

from pbtools import report as R


class _Refs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs, self.imgs, self.scripts, self.script_srcs = [], [], 0, []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "script":
            self.scripts += 1
            if "src" in a:
                self.script_srcs.append(a["src"])
        for key in ("src", "href"):
            if key in a:
                self.refs.append(a[key])
        if tag == "img":
            self.imgs.append(a.get("src"))


class ReportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", seed=11)
        with redirect_stdout(io.StringIO()):
            cls.rc = R.main([cls.run_dir, "--crop", "20,30,24,12"])
        cls.report = os.path.join(cls.run_dir, "report")
        with open(os.path.join(cls.report, "index.html"), encoding="utf-8") as f:
            cls.html = f.read()
        cls.parsed = _Refs()
        cls.parsed.feed(cls.html)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_self_contained(self):
        self.assertEqual(self.rc, 0)
        # The image viewer's one script is inline (with its data as JSON blocks): nothing is fetched.
        self.assertEqual(self.parsed.script_srcs, [])
        self.assertNotRegex(self.html, r"(?i)(https?:)?//[a-z0-9]")  # no external URL at all
        for ref in self.parsed.refs:
            if ref.startswith("#"):
                continue
            self.assertFalse(os.path.isabs(ref), ref)
            self.assertNotIn("..", ref)
            self.assertTrue(os.path.isfile(os.path.join(self.report, ref)), ref)

    def test_every_figure_in_three_formats_with_data(self):
        figures = os.path.join(self.report, "figures")
        stems = {os.path.splitext(n)[0] for n in os.listdir(figures)}
        kinds = {re.sub(r"_.*", "", s) for s in stems}
        self.assertEqual(kinds, {"quality", "passes", "timeline", "sweep", "images"})
        self.assertEqual(len(stems), 2 * 4 + 4)  # 4 per scene + 2 sweeps per scene
        for s in stems:
            for ext in ("svg", "pdf", "png", "csv"):
                path = os.path.join(figures, f"{s}.{ext}")
                self.assertTrue(os.path.getsize(path) > 0, path)
            with open(os.path.join(figures, f"{s}.pdf"), "rb") as f:
                self.assertEqual(f.read(5), b"%PDF-")
            with open(os.path.join(figures, f"{s}.png"), "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
            with open(os.path.join(figures, f"{s}.svg"), encoding="utf-8") as f:
                self.assertIn("<svg", f.read(2000))
        # Plots are shown as SVG (vector), image grids as PNG.
        self.assertTrue(all(src.endswith(".svg") for src in self.parsed.imgs if "images_" not in src))
        self.assertTrue(all(src.endswith(".png") for src in self.parsed.imgs if "images_" in src))
        self.assertEqual(len(self.parsed.imgs), len(stems))

    def test_crop_option_reaches_the_image_grid(self):
        with open(os.path.join(self.report, "figures", "images_pillars.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        self.assertEqual({(r["crop_x"], r["crop_y"], r["crop_w"], r["crop_h"]) for r in rows},
                         {("20", "30", "24", "12")})

    def test_failed_cells_shown(self):
        self.assertIn("3 failed", self.html)
        self.assertIn("VK_ERROR_OUT_OF_DEVICE_MEMORY", self.html)
        self.assertIn("photon buffer full", self.html)  # warnings listed
        with open(os.path.join(self.report, "tables", "summary.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        with open(os.path.join(self.run_dir, "summary.csv"), newline="") as f:
            source = list(csv.DictReader(f))
        self.assertEqual([r["cell"] for r in rows], [r["cell"] for r in source])
        self.assertEqual(sum(r["status"] == "failed" for r in rows), 3)

    def test_latex_booktabs(self):
        with open(os.path.join(self.report, "tables", "summary.tex"), encoding="utf-8") as f:
            tex = f.read()
        for cmd in (r"\toprule", r"\midrule", r"\bottomrule", r"\begin{tabular}", r"\end{tabular}"):
            self.assertIn(cmd, tex)
        self.assertNotIn(r"\hline", tex)
        body = tex.split(r"\midrule", 1)[1]
        rows = [line for line in body.splitlines() if line.endswith(r"\\")]
        self.assertEqual(len(rows), 16)  # one per cell, failed included
        self.assertEqual(sum(r"\emph{failed}" in r for r in rows), 3)
        self.assertIn(r"VK\_ERROR\_OUT\_OF\_DEVICE\_MEMORY", tex)  # escaped
        n_cols = tex.split("{tabular}{", 1)[1].split("}", 1)[0]
        header = body and tex.split(r"\toprule", 1)[1].split(r"\\", 1)[0]
        self.assertEqual(header.count("&") + 1, len(n_cols))
        # The fastest ok cell of each scene is bold in the median column. No scene's best score is
        # resolved from its runner-up (the fixture's neighbouring scores lie within their floors),
        # so no score is bold (tables.best_mask).
        self.assertEqual(tex.count(r"\textbf{"), 2)
        for scene in ("cornell-box", "pillars"):
            self.assertTrue(os.path.isfile(os.path.join(self.report, "tables", f"passes_{scene}.tex")))


class LatexEscapeTest(unittest.TestCase):
    def test_escape(self):
        from pbtools.tables import latex_escape
        self.assertEqual(latex_escape("a_b & 50% #1 {x} ~ ^ \\"),
                         r"a\_b \& 50\% \#1 \{x\} \textasciitilde{} \textasciicircum{} \textbackslash{}")


class HostileNamesTest(unittest.TestCase):
    """Names are text: a scene, technique, reason, warning or device holding markup shows as written
    in the report and the history page (autoescaped templates) and in LaTeX (escaped), and adds no
    element to either page."""

    SCENE = 'cornell-box <script>alert("scene")</script> & co'
    TECHNIQUE = "direct<b>bold</b>&amp;"
    REASON = "<img src=x onerror=alert(1)> & failed"
    DEVICE = "gpu <script>alert('device')</script>"

    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("hostile", seed=3, images=False, scenes=["cornell-box"],
                                   techniques=["direct", "broken"])
        summary = os.path.join(cls.run_dir, "summary.csv")
        with open(summary, newline="") as f:
            rows = list(csv.reader(f))
        for r in rows[1:]:
            r[1] = cls.SCENE
            if r[2] == "direct":
                r[2] = cls.TECHNIQUE
        with open(summary, "w", newline="") as f:
            csv.writer(f).writerows(rows)
        broken = os.path.join(cls.run_dir, "cells", "001-cornell-box-broken", "cell.json")
        with open(broken) as f:
            info = json.load(f)
        info["reason"] = cls.REASON
        info["warnings"] = [{"frame": 1, "message": "<i>warned</i>"}]
        with open(broken, "w") as f:
            json.dump(info, f)
        run_json = os.path.join(cls.run_dir, "run.json")
        with open(run_json) as f:
            info = json.load(f)
        info["device"] = cls.DEVICE
        with open(run_json, "w") as f:
            json.dump(info, f)
        with redirect_stdout(io.StringIO()):
            assert R.main([cls.run_dir]) == 0
        with open(os.path.join(cls.run_dir, "report", "index.html"), encoding="utf-8") as f:
            cls.html = f.read()

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def page(self, text):
        parsed = _Text()
        parsed.feed(text)
        return parsed

    def test_markup_in_names_is_shown_as_text(self):
        parsed = self.page(self.html)
        self.assertEqual(parsed.tags["script"], 0)
        self.assertEqual(parsed.tags["i"], 0)
        self.assertTrue(parsed.img_srcs)
        self.assertTrue(all(src.startswith("figures/") for src in parsed.img_srcs))
        # The page's own bold (best values) only: the technique's <b> is not an element.
        self.assertNotIn("bold", [t for tag, t in parsed.inside if tag == "b"])
        for text in (self.SCENE, self.TECHNIQUE, self.REASON, self.DEVICE, "<i>warned</i>"):
            self.assertIn(text, parsed.texts, text)
        self.assertIn("&lt;script&gt;", self.html)
        self.assertIn("&amp;amp;", self.html)  # the literal "&amp;" in the name, escaped once

    def test_latex_escapes_them(self):
        path = os.path.join(self.run_dir, "report", "tables", "summary.tex")
        with open(path, encoding="utf-8") as f:
            tex = f.read()
        self.assertIn(r"direct<b>bold</b>\&amp;", tex)
        self.assertIn(r"\& co", tex)

    def test_history_page_too(self):
        from pbtools import history as H
        file = self.tmp.path("history.jsonl")
        with redirect_stdout(io.StringIO()):
            self.assertEqual(H.main(["append", self.run_dir, "--file", file]), 0)
            self.assertEqual(H.main(["plot", "--file", file, "--out", self.tmp.path("plots")]), 0)
        with open(self.tmp.path("plots", "index.html"), encoding="utf-8") as f:
            parsed = self.page(f.read())
        self.assertEqual(parsed.tags["script"], 0)
        self.assertIn(self.DEVICE, parsed.texts)


class _Text(HTMLParser):
    """Counts elements and collects every text node (entities decoded) and attribute value."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags, self.texts, self.inside, self.open = collections.Counter(), [], [], []
        self.img_srcs = []

    def handle_starttag(self, tag, attrs):
        self.tags[tag] += 1
        if tag == "img":
            self.img_srcs.append(dict(attrs).get("src", ""))
        self.open.append(tag)
        self.texts += [v for _, v in attrs if v]

    def handle_endtag(self, tag):
        if self.open and self.open[-1] == tag:
            self.open.pop()

    def handle_data(self, data):
        self.texts.append(data.strip())
        if self.open:
            self.inside.append((self.open[-1], data))


if __name__ == "__main__":
    unittest.main()
