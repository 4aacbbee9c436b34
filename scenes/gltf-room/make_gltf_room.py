#!/usr/bin/env python3
"""Writes gltf-room.gltf beside this script: a glTF 2.0 Cornell box (white, red and green walls),
a glass sphere (KHR_materials_transmission + KHR_materials_ior), a rough metal block, a point
light (KHR_lights_punctual) and a camera that sweeps across the box in two seconds (translation
and rotation channels). Every buffer is embedded as a base64 data URI, so the .gltf is the whole
scene. The harness reads it as a scene directly (`scenes: [scenes/gltf-room/gltf-room.gltf]`).

    python3 scenes/gltf-room/make_gltf_room.py
"""
import base64
import json
import math
import pathlib
import struct


class Gltf:
    """A glTF document with one buffer that accessors append to."""

    def __init__(self):
        self.doc = {"asset": {"version": "2.0", "generator": "photonbench make_gltf_room.py"},
                    "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [],
                    "materials": [], "accessors": [], "bufferViews": [],
                    "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission",
                                       "KHR_materials_ior"]}
        self.data = bytearray()

    def accessor(self, values, kind, component="f", minmax=False):
        """values: a flat list; kind: SCALAR, VEC3, VEC4; component: f (float) or H (uint16)."""
        while len(self.data) % 4:
            self.data.append(0)
        offset = len(self.data)
        self.data += struct.pack(f"<{len(values)}{component}", *values)
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[kind]
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": offset,
                                        "byteLength": len(self.data) - offset})
        accessor = {"bufferView": len(self.doc["bufferViews"]) - 1,
                    "componentType": 5126 if component == "f" else 5123,
                    "count": len(values) // width, "type": kind}
        if minmax:  # the specification requires POSITION's bounds
            columns = [values[i::width] for i in range(width)]
            accessor["min"] = [min(c) for c in columns]
            accessor["max"] = [max(c) for c in columns]
        self.doc["accessors"].append(accessor)
        return len(self.doc["accessors"]) - 1

    def mesh(self, positions, normals, indices, material):
        primitive = {"attributes": {"POSITION": self.accessor(positions, "VEC3", minmax=True),
                                    "NORMAL": self.accessor(normals, "VEC3")},
                     "indices": self.accessor(indices, "SCALAR", "H"), "material": material}
        self.doc["meshes"].append({"primitives": [primitive]})
        return len(self.doc["meshes"]) - 1

    def material(self, name, **fields):
        self.doc["materials"].append({"name": name, **fields})
        return len(self.doc["materials"]) - 1

    def node(self, **fields):
        self.doc["nodes"].append(fields)
        index = len(self.doc["nodes"]) - 1
        self.doc["scenes"][0]["nodes"].append(index)
        return index

    def write(self, path):
        self.doc["buffers"] = [{"byteLength": len(self.data),
                                "uri": "data:application/octet-stream;base64," +
                                       base64.b64encode(bytes(self.data)).decode()}]
        path.write_text(json.dumps(self.doc, indent=1) + "\n")


def quad():
    """A unit square in the xz plane facing +y, centred on the origin."""
    positions = [-0.5, 0, -0.5, -0.5, 0, 0.5, 0.5, 0, 0.5, 0.5, 0, -0.5]
    return positions, [0, 1, 0] * 4, [0, 1, 2, 0, 2, 3]


def box():
    """A unit cube centred on the origin, four vertices a face for flat normals."""
    positions, normals, indices = [], [], []
    for axis in range(3):
        for sign in (-1, 1):
            n = [0, 0, 0]
            n[axis] = sign
            u, v = [0, 0, 0], [0, 0, 0]
            u[(axis + 1) % 3] = 1
            v[(axis + 2) % 3] = 1
            if sign < 0:
                u, v = v, u
            base = len(positions) // 3
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                positions += [0.5 * (n[k] + a * u[k] + b * v[k]) for k in range(3)]
                normals += n
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    return positions, normals, indices


def sphere(radius, rings=32, segments=64):
    positions, normals, indices = [], [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            n = [math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)]
            positions += [radius * c for c in n]
            normals += n
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            if i > 0:
                indices += [a, b, a + 1]
            if i < rings - 1:
                indices += [a + 1, b, b + 1]
    return positions, normals, indices


def axis_angle(axis, degrees):
    s = math.sin(math.radians(degrees) / 2)
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(math.radians(degrees) / 2)]


def look_rotation(eye, target):
    """The quaternion (x, y, z, w) turning -z towards target - eye with +y kept up."""
    f = [t - e for t, e in zip(target, eye)]
    length = math.sqrt(sum(c * c for c in f))
    f = [c / length for c in f]
    yaw = math.atan2(-f[0], -f[2])
    pitch = math.asin(f[1])
    qy = axis_angle([0, 1, 0], math.degrees(yaw))
    qx = axis_angle([1, 0, 0], math.degrees(pitch))
    # qy * qx: pitch about the camera's own x, then yaw about world y.
    x1, y1, z1, w1 = qy
    x2, y2, z2, w2 = qx
    return [w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2]


def main():
    g = Gltf()
    pbr = lambda colour, metallic=0.0, roughness=1.0: {  # noqa: E731
        "baseColorFactor": colour + [1.0], "metallicFactor": metallic,
        "roughnessFactor": roughness}
    white = g.material("white", pbrMetallicRoughness=pbr([0.725, 0.71, 0.68]))
    red = g.material("red", pbrMetallicRoughness=pbr([0.63, 0.065, 0.05]))
    green = g.material("green", pbrMetallicRoughness=pbr([0.14, 0.45, 0.091]))
    glass = g.material("glass", pbrMetallicRoughness=pbr([1.0, 1.0, 1.0], 0.0, 0.0),
                       extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                   "KHR_materials_ior": {"ior": 1.5}})
    metal = g.material("metal", pbrMetallicRoughness=pbr([0.95, 0.64, 0.54], 1.0, 0.4))

    wall = lambda material: g.mesh(*quad(), material)  # noqa: E731
    white_wall, red_wall, green_wall = wall(white), wall(red), wall(green)
    g.node(name="floor", mesh=white_wall, translation=[0.5, 0, 0.5])
    g.node(name="ceiling", mesh=white_wall, translation=[0.5, 1, 0.5],
           rotation=axis_angle([1, 0, 0], 180))
    g.node(name="back", mesh=white_wall, translation=[0.5, 0.5, 0],
           rotation=axis_angle([1, 0, 0], 90))
    g.node(name="left", mesh=red_wall, translation=[0, 0.5, 0.5],
           rotation=axis_angle([0, 0, 1], -90))
    g.node(name="right", mesh=green_wall, translation=[1, 0.5, 0.5],
           rotation=axis_angle([0, 0, 1], 90))
    g.node(name="sphere", mesh=g.mesh(*sphere(0.18), glass), translation=[0.62, 0.18, 0.55])
    g.node(name="block", mesh=g.mesh(*box(), metal), translation=[0.28, 0.25, 0.3],
           rotation=axis_angle([0, 1, 0], 20), scale=[0.24, 0.5, 0.24])

    # A point light under the ceiling: 2.5 W/sr, written in candela at 683 lm/W.
    g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "bulb", "type": "point", "color": [1.0, 0.9, 0.75], "intensity": 2.5 * 683}]}}
    g.node(name="bulb", translation=[0.5, 0.9, 0.6], extensions={"KHR_lights_punctual": {"light": 0}})

    # The camera sweeps from the left to the right of the opening, always looking at the sphere's
    # side of the box.
    g.doc["cameras"] = [{"name": "sweep", "type": "perspective",
                         "perspective": {"yfov": math.radians(39.3), "znear": 0.01, "zfar": 100}}]
    times = [0.0, 0.5, 1.0, 1.5, 2.0]
    target = [0.5, 0.35, 0.4]
    eyes = [[0.5 + 0.6 * math.sin(math.radians(a)), 0.5, 0.4 + 2.0 * math.cos(math.radians(a))]
            for a in (-15, -7.5, 0, 7.5, 15)]
    camera = g.node(name="camera", camera=0, translation=eyes[0], rotation=look_rotation(eyes[0], target))
    key_times = g.accessor(times, "SCALAR", minmax=True)
    g.doc["animations"] = [{"name": "sweep", "samplers": [
        {"input": key_times, "output": g.accessor([c for e in eyes for c in e], "VEC3")},
        {"input": key_times,
         "output": g.accessor([c for e in eyes for c in look_rotation(e, target)], "VEC4")}],
        "channels": [{"sampler": 0, "target": {"node": camera, "path": "translation"}},
                     {"sampler": 1, "target": {"node": camera, "path": "rotation"}}]}]
    g.write(pathlib.Path(__file__).resolve().parent / "gltf-room.gltf")


if __name__ == "__main__":
    main()
