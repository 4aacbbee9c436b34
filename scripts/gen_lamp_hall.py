#!/usr/bin/env python3
"""Writes the lamp-hall scene: Paper III of seed 002 in miniature (many emissive triangles).

A 16 x 16 m hall, 4 m high, with a ceiling of small emissive quads (two triangles each) in four power
classes whose radiances span 100x (1, 4.64, 21.5, 100 W/(m^2 sr), assigned in a repeating 2 x 2
pattern so that every region holds every class), spot lights along the walls aimed at the floor,
and a grid of pillars that shadow the floor. The ceiling is one OBJ with one MTL material per power
class (each class becomes one emissive object: few shadow cubes for the shadow-mapped direct light).

    scripts/gen_lamp_hall.py [--emitters 1152] [--spots 16] [--name lamp-hall]
    scripts/gen_lamp_hall.py --lanterns 16 --name lamp-hall-moving

--lanterns N (Paper IV's dynamic lights): N lanterns orbit the hall 2.4 m up, each an emissive torus of
512 triangles (its own emissive object: a bottom-level tree of its own in a two-level light BVH) with a
point light at its centre whose keyframed `power` track flashes (0.1 to 4 W/sr, out of phase), and
whose torus pulses in scale (its triangles' flux follows their area): every frame the lights move and
change flux, so the light BVH is rebuilt or refit (Paper IV, Tables 1 and 2 and Fig. 7). The default 0
is the static lamp-hall.

--emitters is the number of emissive triangles (64 .. 16384; rounded down to an even square grid of
quads); the committed scenes/lamp-hall.yaml is the default. --spots: lavapipe's 16384-texel image
limit holds the shadow atlas of at most ~160 shadow tiles at the default 512-texel tiles, six per
spot, so the default scene has 16 spots where Paper III's hall has more.
"""

import argparse
import math
import pathlib

CLASSES = [1.0, 100.0 ** (1 / 3), 100.0 ** (2 / 3), 100.0]  # radiance, W/(m^2 sr)
HALL = 16.0
HEIGHT = 4.0
LANTERN_RADIANCE = 12.0  # W/(m^2 sr): a 0.25 m torus of 0.06 m tube, 0.59 m^2, about 22 W
LANTERN_PERIOD = 8.0  # s per orbit
FLASH_PERIOD = 1.0  # s per flash


def flash(t: float) -> float:
    """A flash over one period: bright for its first fifth, dim the rest."""
    t %= 1.0
    return 4.0 if t < 0.1 else 0.1 + 3.9 * max(0.0, 1 - (t - 0.1) / 0.1) if t < 0.2 else 0.1


def lanterns(count: int):
    """(light entries, object entries) of `count` orbiting, flashing lanterns."""
    lights, objects = [], []
    for k in range(count):
        phase = 360.0 * k / max(count, 1)
        radius = 3.0 if k % 2 == 0 else 5.5
        orbit = (f"{{orbit: {{center: [0, 0, 0], radius: {radius}, height: 2.4, "
                 f"period: {LANTERN_PERIOD if k % 2 == 0 else -LANTERN_PERIOD}, phase_deg: {phase:.1f}}}}}")
        offset = k / max(count, 1)
        keys = ", ".join(f"[{t:.2f}, {flash(t + offset):.3f}]" for t in [i * 0.05 for i in range(21)])
        lights.append(f"  - {{name: lantern{k}-flame, type: point, position: {orbit}, color: [1.0, 0.8, 0.5],\n"
                      f"     intensity: {{keys: [{keys}],\n"
                      f"                 interpolation: linear, loop: true}}}}")
        pulse = ", ".join(f"[{t:.2f}, [{s:.2f}, {s:.2f}, {s:.2f}]]" for t, s in
                          ((0.0, 1.0), (0.75, 0.6), (1.5, 1.0)))
        objects.append(f"  - {{name: lantern{k}, shape: {{type: torus, major_radius: 0.25, minor_radius: 0.06, "
                       f"segments: [32, 8]}},\n     material: lantern, transform: {{translate: {orbit}, "
                       f"rotate_deg: [90, 0, 0],\n     scale: {{keys: [{pulse}], loop: true}}}}}}")
    return lights, objects


def write_ceiling(folder: pathlib.Path, emitters: int) -> int:
    quads_per_side = max(4, int(math.isqrt(emitters // 2)))
    quads_per_side -= quads_per_side % 2  # the 2 x 2 class pattern tiles the grid
    cell = HALL / quads_per_side
    size = 0.4 * cell  # each lamp covers 16% of its cell
    lines = ["# lamp-hall ceiling: scripts/gen_lamp_hall.py", "mtllib ceiling.mtl", "vn 0 -1 0"]
    faces = {c: [] for c in range(4)}
    vertex = 0
    for i in range(quads_per_side):
        for j in range(quads_per_side):
            x = -HALL / 2 + (i + 0.5) * cell
            z = -HALL / 2 + (j + 0.5) * cell
            h = size / 2
            # Wound to face -y: (x-h, z-h) -> (x-h, z+h) -> (x+h, z+h) -> (x+h, z-h) seen from below.
            for dx, dz in ((-h, -h), (h, -h), (h, h), (-h, h)):
                lines.append(f"v {x + dx:.5f} {HEIGHT - 0.01:.5f} {z + dz:.5f}")
            a = vertex + 1
            faces[(i % 2) * 2 + (j % 2)].append((a, a + 1, a + 2, a + 3))
            vertex += 4
    for c in range(4):
        lines.append(f"usemtl class{c}")
        for a, b, cc, d in faces[c]:
            lines.append(f"f {a}//1 {b}//1 {cc}//1")
            lines.append(f"f {a}//1 {cc}//1 {d}//1")
    (folder / "ceiling.obj").write_text("\n".join(lines) + "\n")
    mtl = ["# lamp-hall power classes: radiance spanning 100x"]
    for c, radiance in enumerate(CLASSES):
        mtl += [f"newmtl class{c}", "Kd 0.8 0.8 0.8", f"Ke {radiance:.4f} {radiance:.4f} {radiance:.4f}"]
    (folder / "ceiling.mtl").write_text("\n".join(mtl) + "\n")
    return 2 * quads_per_side * quads_per_side


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--emitters", type=int, default=1152)
    parser.add_argument("--spots", type=int, default=16)
    parser.add_argument("--name", default="lamp-hall")
    parser.add_argument("--lanterns", type=int, default=0)
    args = parser.parse_args()
    if not 0 <= args.lanterns <= 64:
        parser.error(f"--lanterns: {args.lanterns} outside [0, 64]")
    if not 64 <= args.emitters <= 16384:
        parser.error(f"--emitters: {args.emitters} outside [64, 16384]")
    if not 0 <= args.spots <= 64:
        parser.error(f"--spots: {args.spots} outside [0, 64]")
    scenes = pathlib.Path(__file__).resolve().parent.parent / "scenes"
    folder = scenes / args.name
    folder.mkdir(exist_ok=True)
    triangles = write_ceiling(folder, args.emitters)
    spots = []
    for k in range(args.spots):
        # Around the walls, 0.5 m in, 3 m up, aimed at the floor 3 m towards the centre.
        t = (k + 0.5) / max(args.spots, 1)
        angle = 2 * math.pi * t
        px, pz = 7.5 * math.cos(angle), 7.5 * math.sin(angle)
        tx, tz = 4.5 * math.cos(angle), 4.5 * math.sin(angle)
        intensity = [2.0, 6.0, 20.0][k % 3]
        spots.append(
            f"  - {{name: spot{k}, type: spot, position: [{px:.3f}, 3.0, {pz:.3f}], "
            f"target: [{tx:.3f}, 0.0, {tz:.3f}], intensity: {intensity}, inner_deg: 15, outer_deg: 25}}")
    lantern_lights, lantern_objects = lanterns(args.lanterns)
    spots += lantern_lights
    pillars = []
    for i in range(4):
        for j in range(4):
            x, z = -6 + 4 * i, -6 + 4 * j
            pillars.append(
                f"  - {{name: pillar{i}{j}, shape: {{type: box, size: [0.5, {HEIGHT - 0.02}, 0.5]}}, "
                f"material: stone, transform: {{translate: [{x}, {(HEIGHT - 0.02) / 2:.3f}, {z}]}}}}")
    moving_note, moving_purpose = "", ""
    animation_note = "lamps, spots and pillars stay put."
    lantern_material = ""
    if args.lanterns:
        moving_note = (f"# Plus Paper IV's dynamic lights (--lanterns {args.lanterns}): {args.lanterns} lanterns, "
                       f"emissive tori of 512 triangles,\n# orbiting 2.4 m up, each with a flashing point "
                       "light (keyframed power) at its centre.\n")
        animation_note = (f"the lanterns orbit ({LANTERN_PERIOD:g} s a turn,\n# alternate rings opposite "
                          f"ways), pulse in scale (1.5 s) and flash ({FLASH_PERIOD:g} s, out of phase).")
        moving_purpose = (f"\n  Plus {args.lanterns} orbiting, flashing lanterns (Paper IV): the light BVH "
                          "rebuilt or refit every frame.")
        lantern_material = (f"  lantern: {{type: emissive, emission: [{LANTERN_RADIANCE}, "
                            f"{0.8 * LANTERN_RADIANCE:g}, {0.5 * LANTERN_RADIANCE:g}], albedo: 0.5}}\n")
    text = f"""# {args.name}: Paper III of seed 002 (Moreau & Clarberg, "Importance Sampling of Many Lights on the
# GPU") in miniature, generated by scripts/gen_lamp_hall.py --emitters {args.emitters} --spots {args.spots}:
# a 16 x 16 m hall whose ceiling holds {triangles} emissive triangles in four power classes spanning 100x
# (radiance 1, 4.64, 21.5, 100 W/(m^2 sr) in a 2 x 2 pattern), {args.spots} spots along the walls and 16
# pillars that shadow the floor. The many-light next-event estimator's setting: a uniform light choice
# spends most samples on dim or far lamps, the light BVH's walk on the bright, near, facing ones.
{moving_note}# Regenerate rather than edit.
purpose: >-
  Many-light direct light (Paper III): {triangles} emissive ceiling triangles in four power classes
  spanning 100x, {args.spots} spots and pillars, for comparing uniform, power and light-BVH sampling.{moving_purpose}
fps: 30
frames: 8

# Animation: the camera sways slowly (a closed loop over 2 s); {animation_note}
camera:
  position: {{keys: [[0, [0, 1.7, 7.5]], [1, [0.6, 1.8, 7.2]], [2, [0, 1.7, 7.5]]],
             interpolation: catmull-rom, loop: true}}
  target: [0, 1.2, 0]
  fov_deg: 60

lights:
{chr(10).join(spots) if spots else "  []"}

materials:
  floor: {{type: diffuse, albedo: [0.6, 0.58, 0.55]}}
  wall: {{type: diffuse, albedo: [0.5, 0.5, 0.55]}}
  stone: {{type: diffuse, albedo: [0.7, 0.66, 0.6]}}
{lantern_material}
objects:
  - {{name: floor, shape: {{type: quad, size: [{HALL}, {HALL}]}}, material: floor}}
  - {{name: ceiling, shape: {{type: quad, size: [{HALL}, {HALL}]}}, material: wall,
     transform: {{translate: [0, {HEIGHT}, 0], rotate_deg: [180, 0, 0]}}}}
  - {{name: back, shape: {{type: quad, size: [{HALL}, {HEIGHT}]}}, material: wall,
     transform: {{translate: [0, {HEIGHT / 2}, -{HALL / 2}], rotate_deg: [90, 0, 0]}}}}
  - {{name: left, shape: {{type: quad, size: [{HEIGHT}, {HALL}]}}, material: wall,
     transform: {{translate: [-{HALL / 2}, {HEIGHT / 2}, 0], rotate_deg: [0, 0, -90]}}}}
  - {{name: right, shape: {{type: quad, size: [{HEIGHT}, {HALL}]}}, material: wall,
     transform: {{translate: [{HALL / 2}, {HEIGHT / 2}, 0], rotate_deg: [0, 0, 90]}}}}
  - {{name: lamps, shape: {{type: obj, file: {args.name}/ceiling.obj}}}}
{chr(10).join(pillars + lantern_objects)}
"""
    (scenes / f"{args.name}.yaml").write_text(text)
    print(f"wrote scenes/{args.name}.yaml: {triangles} emissive triangles, {args.spots} spots, "
          f"{args.lanterns} lanterns")


if __name__ == "__main__":
    main()
