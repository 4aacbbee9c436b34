"""matching: the equal-time and equal-quality tables of a match run, from a hand-written match.csv and
match_probes.csv: the order by error or by time, resolved or not by the floors, the seeds and the time
spread; unmatched rows kept with their reason; the probes' figure and its data; the report's section."""

import csv
import os
import shutil
import tempfile
import unittest

import common  # noqa: F401  (puts tools/ on the import path)

from pbtools import matching, style

MATCH_HEADER = ["scene", "technique", "at", "target", "tolerance", "knob", "knob_value", "status",
                "probes", "cell", "wall_ms_median", "wall_ms_p5", "wall_ms_p95", "wall_ms_n",
                "rounds", "probe_wall_ms_median", "flip", "flip_floor", "seeds", "flip_seed_sd", "reason"]
PROBE_HEADER = ["scene", "technique", "knob", "role", "index", "knob_value", "cell", "status",
                "wall_ms_median", "wall_ms_p5", "wall_ms_p95", "flip", "flip_floor"]


def row(technique, status, flip, floor, ms, p5, p95, sd="", at="time", reason=""):
    return {"scene": "box", "technique": technique, "at": at, "target": "250", "tolerance": "0.05",
            "knob": "photons", "knob_value": "1000", "status": status, "probes": "4",
            "cell": f"box__{technique}__0", "wall_ms_median": ms, "wall_ms_p5": p5,
            "wall_ms_p95": p95, "wall_ms_n": "15", "rounds": "3", "probe_wall_ms_median": ms,
            "flip": flip, "flip_floor": floor, "seeds": "1", "flip_seed_sd": sd, "reason": reason}


def write(path, header, rows):
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=header)
        w.writeheader()
        w.writerows(rows)


class TablesTest(unittest.TestCase):
    def test_equal_time_orders_by_error_and_marks_what_the_floors_resolve(self):
        rows = [row("b", "matched", "0.20", "0.06", "250", "240", "260"),
                row("a", "matched", "0.10", "0.01", "251", "240", "262"),
                row("c", "matched", "0.205", "0.06", "249", "240", "262"),
                row("d", "unreachable", "0.5", "0.01", "900", "890", "910", reason="the probes reached 800")]
        t = matching.scene_table(rows, "flip")
        self.assertEqual([r["technique"] for r in t["rows"]], ["a", "b", "c", "d"])
        self.assertEqual(t["rows"][0]["order"], "resolved against b")
        # 0.005 apart, each within 4x its floor of 0.06: the order may be the reference's noise.
        self.assertEqual(t["rows"][1]["order"], "unresolved against c")
        self.assertEqual(t["rows"][2]["order"], "")
        self.assertEqual(t["rows"][3]["status"], "unreachable")
        self.assertIn("the probes reached 800", t["rows"][3]["reason"])
        self.assertEqual(t["rows"][0]["time"], "251 [240, 262]")
        self.assertIn("floor 0.01", t["rows"][0]["score"])

    def test_seeds_can_leave_an_order_the_floors_resolve_unresolved(self):
        rows = [row("a", "matched", "0.10", "0.001", "250", "240", "260", sd="0.03"),
                row("b", "matched", "0.15", "0.001", "250", "240", "260", sd="0.03")]
        t = matching.scene_table(rows, "flip")
        self.assertEqual(t["rows"][0]["order"], "unresolved against b")  # 0.05 < 2 sqrt(2) 0.03
        rows[1]["flip"] = "0.30"
        self.assertEqual(matching.scene_table(rows, "flip")["rows"][0]["order"], "resolved against b")

    def test_equal_quality_orders_by_time_and_resolves_by_the_spread(self):
        rows = [row("slow", "matched", "0.15", "0.01", "400", "380", "420", at="quality"),
                row("fast", "matched", "0.15", "0.01", "100", "90", "110", at="quality"),
                row("close", "matched", "0.15", "0.01", "410", "390", "430", at="quality")]
        t = matching.scene_table(rows, "flip")
        self.assertEqual(t["mode"], "quality")
        self.assertEqual([r["technique"] for r in t["rows"]], ["fast", "slow", "close"])
        self.assertEqual(t["rows"][0]["order"], "resolved against slow")
        self.assertEqual(t["rows"][1]["order"], "unresolved against close")


class FigureTest(unittest.TestCase):
    def test_the_probes_figure_rings_the_kept_probe_and_writes_its_data(self):
        d = tempfile.mkdtemp()
        try:
            write(os.path.join(d, "match.csv"), MATCH_HEADER,
                  [row("a", "matched", "0.1", "0.01", "250", "240", "260")])
            probes = [{"scene": "box", "technique": "a", "knob": "photons", "role": "probe", "index": str(i),
                       "knob_value": str(k), "cell": "box__a__0" if k == 1000 else f"box__a__{k}",
                       "status": "ok", "wall_ms_median": str(ms), "wall_ms_p5": "", "wall_ms_p95": "",
                       "flip": str(f), "flip_floor": "0.01"}
                      for i, (k, ms, f) in enumerate([(100, 60, 0.3), (400, 150, 0.17), (1000, 250, 0.1)])]
            write(os.path.join(d, "match_probes.csv"), PROBE_HEADER, probes)
            v = matching.view(d, style.TechniqueStyle(["a"]))
            self.assertEqual(v["mode"], "time")
            self.assertEqual(v["target"], 250.0)
            fig = v["scenes"][0]["figure"]
            self.assertEqual(len(fig.rows), 3)
            kept = [r for r in fig.rows if r[fig.header.index("kept")]]
            self.assertEqual([r[fig.header.index("knob_value")] for r in kept], ["1000"])
            self.assertTrue(all(r[fig.header.index("pareto")] for r in fig.rows))  # each faster is worse
            style.close(fig.fig)
        finally:
            shutil.rmtree(d)


if __name__ == "__main__":
    unittest.main()
