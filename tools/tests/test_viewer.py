"""The report's image viewer (pbtools/viewer.py, templates/viewer.js): its images copied beside the page
with their exposure stops, hidden without scripts, and driven in headless Chromium (keys, wheel zoom,
frame change, exposure, swipe) with its state read back from the page."""

import html
import io
import json
import os
import re
import shutil
import subprocess
import unittest
from contextlib import redirect_stderr, redirect_stdout

from common import TempRuns

import numpy as np

from pbtools import report as R
from pbtools import viewer as V

BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")

# Run after 'load' in a copy of the page: drives the first viewer and records its state (the data-*
# attributes it mirrors) and which panels show which image after each step.
DRIVER = """<script>
window.addEventListener('load', function () {
  var out = [], v = document.querySelector('.viewer[data-viewer]');
  function key(k) { document.dispatchEvent(new KeyboardEvent('keydown', {key: k, bubbles: true})); }
  function snap(step) {
    var panels = [].slice.call(v.querySelectorAll('.viewer-panel:not(.viewer-swipe)')).map(function (p) {
      var img = p.querySelector('img');
      return {hidden: p.hidden, src: img.getAttribute('src'), transform: img.style.transform};
    });
    var w = v.querySelector('.viewer-swipe'), imgs = w.querySelectorAll('img');
    out.push({step: step, hidden: v.hidden, cell: v.dataset.cell, frame: v.dataset.frame,
              show: v.dataset.show, zoom: +v.dataset.zoom, x: +v.dataset.x, y: +v.dataset.y,
              ev: +v.dataset.ev, split: +v.dataset.split, panels: panels,
              swipe: {hidden: w.hidden, a: imgs[0].getAttribute('src'), b: imgs[1].getAttribute('src'),
                      clip: w.querySelector('.viewer-swipe-b').style.clipPath,
                      divider: w.querySelector('.viewer-divider').style.left,
                      transform: imgs[1].style.transform,
                      caption: w.querySelector('.viewer-caption').textContent}});
  }
  snap('start');
  v.dispatchEvent(new MouseEvent('mouseenter'));
  key('2'); snap('key 2');
  key('f'); snap('key f');
  key('r'); snap('key r');
  key('['); snap('key [');
  var panel = v.querySelector('.viewer-panel:not([hidden])'), r = panel.getBoundingClientRect();
  panel.dispatchEvent(new WheelEvent('wheel', {deltaY: -100, clientX: r.left + r.width / 4,
                                               clientY: r.top + r.height / 2, bubbles: true,
                                               cancelable: true}));
  snap('wheel in');
  key('a'); snap('key a');
  key('0'); snap('key 0');
  key('+'); snap('key +');
  key('-'); key('-'); snap('key - -');
  v.querySelector('[data-ev="-2"]').click(); snap('button -2');
  key('-'); snap('key - at -2');
  key('='); key('='); snap('key = =');
  key('s'); snap('key s');
  var sw = v.querySelector('.viewer-swipe'), box = sw.getBoundingClientRect();
  sw.dispatchEvent(new PointerEvent('pointermove', {clientX: box.left + 0.3 * box.width,
                                                    clientY: box.top + box.height / 2, bubbles: true}));
  snap('swipe move');
  var pick = v.querySelector('select[data-swipe="b"]');
  pick.value = 'flip:1';
  pick.dispatchEvent(new Event('change'));
  snap('swipe b flip');
  key('2'); snap('swipe key 2');
  sw.dispatchEvent(new WheelEvent('wheel', {deltaY: -100, clientX: box.left + box.width / 2,
                                            clientY: box.top + box.height / 2, bubbles: true,
                                            cancelable: true}));
  snap('swipe wheel');
  var pre = document.createElement('pre');
  pre.id = 'pb-viewer';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


class ViewerTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", frames=16, metrics_every=8, scenes=["cornell-box"],
                                   techniques=["direct", "tiled"],
                                   settings={"tiled": [{"photons": 50000, "radius": 0.05}]})
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            cls.index = R.build(cls.run_dir)
        cls.report = os.path.dirname(cls.index)
        with open(cls.index, encoding="utf-8") as f:
            cls.html = f.read()
        m = re.search(r'<script type="application/json" class="viewer-data">(.*?)</script>', cls.html,
                      re.S)
        cls.data = json.loads(m.group(1)) if m else None

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_every_metric_frame_with_its_images_beside_the_page(self):
        self.assertIsNotNone(self.data)
        self.assertEqual([c["label"] for c in self.data["cells"]], ["direct", "tiled"])
        self.assertEqual([f["frame"] for f in self.data["frames"]], [0, 8])  # the fixture scores every 8th frame
        for f in self.data["frames"]:
            paths = [f["reference"]] + [p for c in f["cells"] for p in (c["image"], c["flip"])]
            for p in paths:
                self.assertTrue(os.path.isfile(os.path.join(self.report, p)), p)
            self.assertNotEqual(f["cells"][0]["image"], f["cells"][1]["image"])

    def test_exposure_stops_written_beside_each_image(self):
        self.assertEqual(self.data["stops"], [-2, -1, 0, 1, 2])
        import matplotlib.image
        for f in self.data["frames"]:
            for stops, original in [(f["reference_stops"], f["reference"])] + [
                    (c["image_stops"], c["image"]) for c in f["cells"]]:
                self.assertEqual(sorted(stops, key=int), ["-2", "-1", "0", "1", "2"])
                self.assertEqual(stops["0"], original)
                pix = {ev: matplotlib.image.imread(os.path.join(self.report, p))[..., :3]
                       for ev, p in stops.items()}
                # Each stop up is brighter where the image is not black or already white ...
                for lo, hi in (("-2", "-1"), ("-1", "0"), ("0", "1"), ("1", "2")):
                    self.assertGreater(pix[hi].mean(), pix[lo].mean(), (lo, hi, original))
                # ... by a factor 2 in linear light (checked on the mid-tones, away from clipping).
                lin = {ev: V.srgb_to_linear(p.astype(float)) for ev, p in pix.items()}
                mid = (lin["0"] > 0.05) & (lin["0"] < 0.4)
                if mid.sum() > 50:
                    ratio = float(np.median(lin["1"][mid] / lin["0"][mid]))
                    self.assertAlmostEqual(ratio, 2.0, delta=0.1)
        # A FLIP map is never re-exposed.
        self.assertFalse([n for n in os.listdir(os.path.join(self.report, "viewer", "cornell-box"))
                          if "flip" in n and "_ev" in n])

    def test_hidden_without_scripts(self):
        self.assertRegex(self.html, r'<section class="viewer"[^>]*\bhidden\b')

    @unittest.skipUnless(BROWSER, "chromium is not installed (tests/e2e/report_html.sh fails on it)")
    def test_keys_and_zoom_in_chromium(self):
        page = os.path.join(self.report, "viewer-check.html")
        with open(page, "w", encoding="utf-8") as f:
            f.write(self.html.replace("</body></html>", DRIVER + "</body></html>"))
        profile = self.tmp.path("profile")
        dom = subprocess.run(
            [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={profile}", "--window-size=1200,900", "--virtual-time-budget=5000",
             "--dump-dom", "file://" + page],
            capture_output=True, text=True, timeout=120).stdout
        m = re.search(r'<pre id="pb-viewer">(.*?)</pre>', dom, re.S)
        self.assertIsNotNone(m, "the driver did not run")
        steps = {s["step"]: s for s in json.loads(html.unescape(m.group(1)))}
        frames = self.data["frames"]
        last, first = frames[-1], frames[0]

        start = steps["start"]
        self.assertFalse(start["hidden"])  # the script shows it
        self.assertEqual((start["cell"], start["frame"], start["show"]), ("0", str(last["frame"]), "all"))
        self.assertEqual([p["src"] for p in start["panels"]],
                         [last["cells"][0]["image"], last["reference"], last["cells"][0]["flip"]])

        self.assertEqual(steps["key 2"]["panels"][0]["src"], last["cells"][1]["image"])
        shown = lambda s: [p["src"] for p in steps[s]["panels"] if not p["hidden"]]
        self.assertEqual(shown("key f"), [last["cells"][1]["flip"]])
        self.assertEqual(shown("key r"), [last["reference"]])
        self.assertEqual(steps["key ["]["frame"], str(first["frame"]))
        self.assertEqual(shown("key ["), [first["reference"]])

        wheel = steps["wheel in"]
        self.assertAlmostEqual(wheel["zoom"], 1.25, places=3)
        # About the pointer at (1/4, 1/2) of the panel: that point stays put.
        self.assertAlmostEqual(wheel["x"], 0.25 - 0.25 * 1.25, places=3)
        self.assertAlmostEqual(wheel["y"], 0.5 - 0.5 * 1.25, places=3)
        # One zoom for every panel: the three show the same transform.
        transforms = {p["transform"] for p in steps["key a"]["panels"]}
        self.assertEqual(len(transforms), 1)
        self.assertIn("scale(1.25)", transforms.pop())
        self.assertEqual((steps["key 0"]["zoom"], steps["key 0"]["x"]), (1, 0))

        # Exposure: the outputs and the reference switch to the pre-rendered stop; FLIP maps stay.
        cell1 = first["cells"][1]
        plus = steps["key +"]
        self.assertEqual(plus["ev"], 1)
        self.assertEqual([p["src"] for p in plus["panels"]],
                         [cell1["image_stops"]["1"], first["reference_stops"]["1"], cell1["flip"]])
        self.assertEqual(steps["key - -"]["ev"], -1)
        self.assertEqual(steps["key - -"]["panels"][1]["src"], first["reference_stops"]["-1"])
        self.assertEqual(steps["button -2"]["ev"], -2)
        self.assertEqual(steps["key - at -2"]["ev"], -2)  # the lowest stop holds
        self.assertEqual(steps["key = ="]["ev"], 0)
        self.assertEqual(steps["key = ="]["panels"][0]["src"], cell1["image"])

        # Swipe: one panel, A the current cell's output, B the reference, divider at the pointer.
        swipe = steps["key s"]
        self.assertEqual(swipe["show"], "swipe")
        self.assertEqual(shown("key s"), [])
        self.assertFalse(swipe["swipe"]["hidden"])
        self.assertTrue(steps["key = ="]["swipe"]["hidden"])
        self.assertEqual((swipe["swipe"]["a"], swipe["swipe"]["b"]), (first["cells"][0]["image"],
                                                                     first["reference"]))
        moved = steps["swipe move"]
        self.assertAlmostEqual(moved["split"], 0.3, places=2)
        self.assertRegex(moved["swipe"]["clip"], r"^inset\(0(px)? 0(px)? 0(px)? 30(\.0+)?%\)$")
        self.assertRegex(moved["swipe"]["divider"], r"^30(\.0+)?%$")
        flip_b = steps["swipe b flip"]["swipe"]
        self.assertEqual(flip_b["b"], first["cells"][1]["flip"])
        self.assertEqual(flip_b["caption"], "A: direct | B: FLIP map of tiled")
        self.assertEqual(steps["swipe key 2"]["swipe"]["a"], first["cells"][1]["image"])
        wheel = steps["swipe wheel"]
        self.assertAlmostEqual(wheel["zoom"], 1.25, places=3)
        self.assertIn("scale(1.25)", wheel["swipe"]["transform"], json.dumps(wheel))


if __name__ == "__main__":
    unittest.main()
