#!/usr/bin/env python3
"""Writes the many-lights stress scenes: the stress room (scenes/stress/room.yaml) with its one point
light split into N point lights of the same total power (seed 002 Papers III and IV against the
per-light machinery of every technique: the shadow atlas's six tiles per light, AAPS's per-light
density textures, Paper II's distribution maps, the RSMs).

    scripts/gen_stress_many_lights.py [--lights 1 16 256]

The lights stand on a square grid 1.2 m wide, 1.8 m above the floor, centred on the room's bulb, each
with intensity 3 / N W/sr: the total power and the lights' centroid are the room's. N must be a
square. Writes scenes/stress/many-lights-N.yaml for each N (N = 1 is the room's bulb itself).
"""

import argparse
import math
import pathlib

BULB = (0.3, 1.8, 0.2)  # scenes/stress/room.yaml's point light
COLOR = "[1.0, 0.9, 0.75]"
INTENSITY = 3.0  # W/sr
SPREAD = 1.2  # m, the grid's width

ROOM = pathlib.Path(__file__).resolve().parent.parent / "scenes" / "stress" / "room.yaml"


def room_body() -> str:
    """room.yaml from `materials:` on (its geometry and materials, unchanged)."""
    text = ROOM.read_text()
    return text[text.index("materials:"):]


def scene(lights: int) -> str:
    side = math.isqrt(lights)
    if side * side != lights or lights < 1:
        raise SystemExit(f"--lights: {lights} is not a positive square")
    lines = [
        f"# stress/many-lights-{lights}: written by scripts/gen_stress_many_lights.py (do not edit).",
        f"# The stress room with its point light split into {lights} point lights of the same total",
        "# power on a grid centred on the room's bulb (Papers III and IV of seed 002: lights that every",
        "# per-light structure must hold). Static, like the room.",
        "purpose: >-",
        f"  Stress: the stress room's bulb split into {lights} point lights of the same total power.",
        "fps: 30",
        "frames: 8",
        "",
        "camera:",
        "  position: [0, 1, 3.2]",
        "  target: [0, 0.8, 0]",
        "  fov_deg: 45",
        "",
        "lights:",
    ]
    for i in range(side):
        for j in range(side):
            offset = (lambda k: 0.0 if side == 1 else SPREAD * (k / (side - 1) - 0.5))
            x, z = BULB[0] + offset(i), BULB[2] + offset(j)
            lines.append(f"  - {{name: bulb{i * side + j}, type: point, position: [{x:.4f}, {BULB[1]}, "
                         f"{z:.4f}], color: {COLOR}, intensity: {INTENSITY / lights:.8g}}}")
    return "\n".join(lines) + "\n\n" + room_body()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--lights", type=int, nargs="+", default=[1, 16, 256])
    args = parser.parse_args()
    for n in args.lights:
        path = ROOM.parent / f"many-lights-{n}.yaml"
        path.write_text(scene(n))
        print(f"wrote {path.relative_to(ROOM.parent.parent.parent)}: {n} point lights")


if __name__ == "__main__":
    main()
