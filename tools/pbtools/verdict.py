"""A verdict per scene: which technique setting scores better, whether this run can tell, what each
step up in quality costs in time, and what would settle an order it cannot tell.

Per scene, one entry per setting (a seed group: `--seeds K` makes K cells of one setting; a match
run's re-measurement round is never one, rundata.Cell.match_round): its FLIP on the composed image
(`combined`, the mean of its seeds' means) with the reference's noise floor, its own path class's
FLIP and floor beside it (a caustics technique is judged on its caustics too), and its frame time
(the wall-clock median of its measured frames, summary.csv's wall_ms_median; the mean over seeds).
The entries are ordered by combined FLIP, lower first, and each neighbouring pair is marked:

    a < b   resolved: the gap is larger than the two floors together (floors.order_holds_in_worst_case:
            by the triangle inequality each score lies within its floor of the score against the
            true image, so the order holds whatever the reference's noise), and, where the settings
            have two or more seeds, Welch's one-sided test across seeds rejects "a is not better"
            at stats.ALPHA (the technique's own Monte Carlo noise).
    a ≈ b   anything else. What would resolve it: a reference whose floors fit in the gap (floors
            scale with the reference's relative error, so reference.rel_error x gap / (floor_a +
            floor_b), or "nothing" when the scores are equal), and seeds where the seed test failed
            or could not run.

This is stricter than floors.comparison_resolved's second rule (both scores resolved and different),
which calls a 0.5% gap between two resolved scores resolved: that rule says the order holds against
the reference's noise only if each technique's own error is exactly what it scored, which one seed
cannot tell. The report's bold "best" and the claims' order tables follow this module.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import List, Optional

from . import floors, seeds, stats
from .rundata import PRIMARY_CLASS, Run

METRIC = "flip"


@dataclass
class Entry:
    label: str
    technique: str
    score: float  # combined FLIP, mean over seeds
    floor: float
    ms: float  # wall-clock median frame time, mean over seeds
    seed_scores: List[float]
    own_class: Optional[str] = None
    own_score: float = math.nan
    own_floor: float = math.nan


@dataclass
class Step:
    """The pair (better, worse) of neighbours in a scene's order."""
    better: Entry
    worse: Entry
    resolved: bool
    by_floors: bool
    seed_test: Optional[stats.Welch]
    needs: List[str] = field(default_factory=list)  # what would resolve it

    @property
    def sign(self) -> str:
        return "<" if self.resolved else "≈"

    @property
    def cost(self) -> str:
        """The time of the step up in quality from `worse` to `better`."""
        a, b = self.better.ms, self.worse.ms
        if not (math.isfinite(a) and math.isfinite(b)) or b <= 0:
            return ""
        if a > b:
            return f"+{a - b:.1f} ms ({a / b:.2f}x)"
        return f"{a - b:.1f} ms ({a / b:.2f}x): better and not slower"


def reference_rel_error(run: Run, scene: str) -> Optional[float]:
    """The relative error `scene`'s full references reached for the composed image (the largest over
    its cells' frames, cell.json "references"); for a run without those records, the config's
    reference.rel_error (run.json's resolved config); None when neither is there. What the scene's
    references reached, not what the config asked: a scene entry can ask for its own stop rules,
    and a reference stopped by its time limit falls short of its target."""
    reached = [r.get("rel_error", 0.0) for c in run.cells if c.ok and c.scene == scene
               for r in c.json.get("references", [])
               if r.get("reference") == "full" and r.get("path_class") == PRIMARY_CLASS]
    if any(e > 0 for e in reached):
        return max(reached)
    config = run.info.get("config")
    if isinstance(config, str):
        m = re.search(r"^reference:.*?\brel_error:\s*([0-9.eE+-]+)", config, re.MULTILINE | re.DOTALL)
        return float(m.group(1)) if m else None
    if isinstance(config, dict):
        value = (config.get("reference") or {}).get("rel_error")
        return float(value) if isinstance(value, (int, float)) else None
    return None


def entries(run: Run, scene: str) -> List[Entry]:
    """Every setting of `scene` with a finite combined FLIP, ordered by it (lower first)."""
    out = []
    for cells in seeds.groups(run).values():
        ok = [c for c in cells if c.ok and c.scene == scene]
        if not ok:
            continue
        first = ok[0]
        per_seed = seeds.per_seed_means(ok, METRIC, PRIMARY_CLASS)
        floor_values = [c.metric_mean(METRIC + floors.FLOOR_SUFFIX, PRIMARY_CLASS) for c in ok]
        floor_values = [v for v in floor_values if math.isfinite(v)]
        if not per_seed:
            continue
        times = [c.value("wall_ms_median") for c in ok]
        times = [t for t in times if math.isfinite(t)]
        entry = Entry(run.label(first, with_seed=False), first.technique,
                      sum(per_seed) / len(per_seed),
                      sum(floor_values) / len(floor_values) if floor_values else math.nan,
                      sum(times) / len(times) if times else math.nan, per_seed)
        own = [k for k in first.metric_classes() if k != PRIMARY_CLASS]
        if own:
            entry.own_class = own[0]
            entry.own_score = first.metric_mean(METRIC, own[0])
            entry.own_floor = first.metric_mean(METRIC + floors.FLOOR_SUFFIX, own[0])
        out.append(entry)
    out.sort(key=lambda e: e.score)
    return out


def step(better: Entry, worse: Entry, rel_error: Optional[float]) -> Step:
    """The verdict on one neighbouring pair (the module's rule)."""
    has_floors = math.isfinite(better.floor) and math.isfinite(worse.floor)
    by_floors = has_floors and floors.order_holds_in_worst_case(
        METRIC, better.score, better.floor, worse.score, worse.floor)
    seeded = len(better.seed_scores) >= 2 and len(worse.seed_scores) >= 2
    test = stats.welch(better.seed_scores, worse.seed_scores, "less") if seeded else None
    by_seeds = test is None or (test.possible and test.p < stats.ALPHA)
    needs = []
    gap = worse.score - better.score
    if not has_floors:
        needs.append("noise floors (this run's scores have none)")
    elif not by_floors:
        floor_sum = better.floor + worse.floor
        if gap <= 0:
            needs.append("nothing: the scores are equal")
        elif rel_error is not None:
            needs.append(f"reference.rel_error <= {rel_error * gap / floor_sum:.2g} (now {rel_error:.3g}): "
                         f"floors summing under the gap {gap:.4f} (now {floor_sum:.4f})")
        else:
            needs.append(f"floors summing under the gap {gap:.4f} (now {floor_sum:.4f}): a finer "
                         "reference")
    if not by_seeds:
        needs.append(f"more seeds (--seeds K; {len(better.seed_scores)} now, p = {test.p:.2g})")
    return Step(better, worse, by_floors and by_seeds, by_floors, test, needs)


@dataclass
class SceneVerdict:
    scene: str
    entries: List[Entry]
    steps: List[Step]
    one_seed: bool

    @property
    def order(self) -> str:
        """"a < b ≈ c": the settings, best first, each pair's sign between them."""
        if not self.entries:
            return ""
        text = self.entries[0].label
        for s in self.steps:
            text += f" {s.sign} {s.worse.label}"
        return text

    @property
    def best_resolved(self) -> bool:
        """Whether the best setting is resolved from the runner-up (a lone setting is not "best")."""
        return bool(self.steps) and self.steps[0].resolved


def scene_verdict(run: Run, scene: str) -> SceneVerdict:
    found = entries(run, scene)
    rel_error = reference_rel_error(run, scene)
    steps = [step(a, b, rel_error) for a, b in zip(found, found[1:])]
    one_seed = all(len(e.seed_scores) < 2 for e in found)
    return SceneVerdict(scene, found, steps, one_seed)


def verdicts(run: Run) -> List[SceneVerdict]:
    return [v for v in (scene_verdict(run, s) for s in run.scenes()) if v.entries]


def _score(value: float, floor: float) -> str:
    if not math.isfinite(value):
        return ""
    return f"{value:.4f}" + (f" (floor {floor:.4f})" if math.isfinite(floor) else "")


def view(run: Run) -> List[dict]:
    """The report's verdict section: per scene the order line, one row per setting (its scores and
    time, and the step from the setting above it: sign, time cost, what would resolve it)."""
    out = []
    for v in verdicts(run):
        rows = []
        for i, e in enumerate(v.entries):
            above = v.steps[i - 1] if i > 0 else None
            rows.append({"label": e.label, "score": _score(e.score, e.floor),
                         "own": (f"{e.own_class}: {_score(e.own_score, e.own_floor)}"
                                 if e.own_class else ""),
                         "ms": f"{e.ms:.1f}" if math.isfinite(e.ms) else "",
                         "seeds": len(e.seed_scores),
                         "sign": above.sign if above else "",
                         "cost": above.cost if above else "",
                         "needs": "; ".join(above.needs) if above else ""})
        out.append({"scene": v.scene, "order": v.order, "rows": rows,
                    "best": v.entries[0].label if v.best_resolved else "",
                    "one_seed": v.one_seed})
    return out
