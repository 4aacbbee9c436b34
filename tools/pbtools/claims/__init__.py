"""photonbench claims RUN_DIR [--paper NAME]: a paper's headline claims, measured on a run.

A run made with a paper's config (configs/paper1.yaml, ...) holds the cells the paper compares; this
command turns them into the comparisons the paper states (speed ratios between techniques, rejection
rates, memory per structure, the quality table) and prints them next to the paper's own numbers, as
markdown, also written to RUN_DIR/report/claims-<paper>.md. Each paper is a module of this package with
`TITLE` and `claims(run) -> str`.
"""

import argparse
import importlib
import os
import sys

from ..rundata import Run, RunError

PAPERS = {"paper1": "Photon Splatting Using a View-Sample Cluster Hierarchy (Moreau et al., HPG 2016)",
          "aaps": "Extending AAPS for higher quality caustic rendering (van Casteren, MSc thesis 2023)",
          "paper2": "Path Verification for Dynamic Indirect Illumination (Moreau, Sintorn et al.)",
          "rsm": "Real-time global illumination with photon mapping (seed 000, Ray Tracing Gems ch. 24)",
          "paper003": "Interactive Global Photon Mapping (Fabianowski and Dingliana, EGSR 2009)",
          "manylights": "Importance Sampling of Many Lights; Dynamic Many-Light Sampling (seed 002 III, IV)",
          "paper001": "Real-time Photon Mapping (Larsen, DTU thesis 2004; seed 001)",
          "ivc": "Real-Time Rendering of Indirectly Visible Caustics (Paper V) against AAPS's splat BVH"}
ALIASES = {"003": "paper003", "001": "paper001"}  # the seed's number, as the issues name it


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="photonbench claims", description=__doc__.split("\n")[0])
    ap.add_argument("run", metavar="RUN_DIR")
    ap.add_argument("--paper", choices=sorted(PAPERS) + sorted(ALIASES), default="paper1",
                    help="whose claims to measure (default %(default)s)")
    a = ap.parse_args(argv)
    a.paper = ALIASES.get(a.paper, a.paper)
    try:
        run = Run(a.run)
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    module = importlib.import_module(f"{__name__}.{a.paper}")
    try:
        text = module.claims(run)
    except module.MissingCells as e:
        print(f"error: {a.run}: {e}", file=sys.stderr)
        return 2
    out_dir = os.path.join(run.path, "report")
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, f"claims-{a.paper}.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    print(text)
    print(f"(written to {path})", file=sys.stderr)
    return 0
