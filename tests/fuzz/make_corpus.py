#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora (tests/fuzz/corpus/<target>/) from the shipped files.

config: every configs/*.yaml; scene: every scenes/*.yaml and the test scenes; obj: every OBJ file
under scenes/ and tests/data/scenes/ with the MTL file it names, as "OBJ \\0 MTL" (fuzz_obj.cpp);
set: each shipped config's settings written as --set lines ("frames.count=32", one per line);
gltf: small glTF documents written here, one per feature the importer reads (each with its buffer
as a data URI), and one as .glb.
Run it again when those files change; scripts/fuzz.sh copies the seeds into build-fuzz/ and
fuzzes from there, so what the fuzzers find never lands here unasked.
"""
import base64
import json
import pathlib
import re
import shutil
import struct

root = pathlib.Path(__file__).resolve().parents[2]
out = root / "tests/fuzz/corpus"


def fresh(target):
    folder = out / target
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    return folder


def set_lines(config_text):
    """The config's block-style settings as --set assignments, nested by indentation; list items
    ("- key: value") become numeric parts, as --set indexes lists."""
    lines, stack, items = [], [], {}
    for raw in config_text.splitlines():
        line = raw.split(" #")[0].rstrip()
        match = re.match(r"^( *)(- )?([A-Za-z_][A-Za-z0-9_]*): ?(.*)$", line)
        if not match:
            continue
        indent, item, key, value = len(match[1]), match[2], match[3], match[4]
        while stack and stack[-1][0] >= indent:
            stack.pop()
        if item:  # a new element of the list at the enclosing key
            parent = ".".join(k for _, k in stack)
            items[parent] = items.get(parent, -1) + 1
            stack.append((indent, str(items[parent])))
            indent += 2
        path = ".".join([k for _, k in stack] + [key])
        if value:
            lines.append(f"{path}={value}")
        else:
            stack.append((indent, key))
    return "\n".join(lines) + "\n"


configs = sorted((root / "configs").glob("*.yaml"))
folder = fresh("config")
for f in configs:
    shutil.copy(f, folder / f.name)
folder = fresh("set")
for f in configs:
    (folder / (f.stem + ".txt")).write_text(set_lines(f.read_text()))

folder = fresh("scene")
for f in sorted((root / "scenes").glob("*.yaml")) + sorted((root / "tests/data/scenes").glob("*.yaml")):
    shutil.copy(f, folder / f.name)

folder = fresh("obj")
for f in sorted((root / "scenes").rglob("*.obj")) + sorted((root / "tests/data/scenes").glob("*.obj")):
    obj = f.read_bytes()
    mtl = b""
    named = re.search(rb"^mtllib\s+(\S+)", obj, re.M)
    if named and (f.parent / named[1].decode()).is_file():
        mtl = b"\0" + (f.parent / named[1].decode()).read_bytes()
    (folder / f.name).write_bytes(obj + mtl)


def gltf_document(extra):
    """A triangle (positions, normals, indices) in a one-node scene, and `extra(doc, accessor)`'s
    additions; returns the document and its binary buffer."""
    data = bytearray()
    doc = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "accessors": [], "bufferViews": []}

    def accessor(values, kind, component="f"):
        while len(data) % 4:
            data.append(0)
        offset = len(data)
        data.extend(struct.pack(f"<{len(values)}{component}", *values))
        doc["bufferViews"].append({"buffer": 0, "byteOffset": offset, "byteLength": len(data) - offset})
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[kind]
        doc["accessors"].append({"bufferView": len(doc["bufferViews"]) - 1,
                                 "componentType": 5126 if component == "f" else 5123,
                                 "count": len(values) // width, "type": kind})
        return len(doc["accessors"]) - 1

    doc["meshes"] = [{"primitives": [{"attributes": {
        "POSITION": accessor([0, 0, 0, 1, 0, 0, 0, 1, 0], "VEC3"),
        "NORMAL": accessor([0, 0, 1] * 3, "VEC3")}, "indices": accessor([0, 1, 2], "SCALAR", "H")}]}]
    extra(doc, accessor)
    return doc, bytes(data)


def embedded(doc, data):
    doc = dict(doc, buffers=[{"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                              + base64.b64encode(data).decode()}])
    return json.dumps(doc).encode()


def glb(doc, data):
    text = json.dumps(dict(doc, buffers=[{"byteLength": len(data)}])).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    chunks = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(data), b"BIN\0") + data
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def materials(doc, accessor):
    doc["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_ior",
                             "KHR_materials_emissive_strength"]
    doc["materials"] = [{"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
                         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                        "KHR_materials_ior": {"ior": 1.33}}},
                        {"emissiveFactor": [1, 1, 1],
                         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}}]
    doc["meshes"][0]["primitives"][0]["material"] = 0


def lights_and_camera(doc, accessor):
    doc["extensionsUsed"] = ["KHR_lights_punctual"]
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "intensity": 100}, {"type": "spot", "spot": {"outerConeAngle": 0.6}},
        {"type": "directional", "color": [1, 0.5, 0.5]}]}}
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01}}]
    doc["nodes"] += [{"camera": 0, "translation": [0, 0, 3]},
                     {"children": [3, 4], "rotation": [0.7071, 0, 0, 0.7071]},
                     {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 2, 0]},
                     {"extensions": {"KHR_lights_punctual": {"light": 1}}, "scale": [1, 2, 1]},
                     {"extensions": {"KHR_lights_punctual": {"light": 2}}}]
    doc["scenes"][0]["nodes"] += [1, 2, 5]


def animation(doc, accessor):
    times = accessor([0, 1, 2], "SCALAR")
    doc["animations"] = [{"samplers": [
        {"input": times, "output": accessor([0, 0, 0, 1, 0, 0, 1, 1, 0], "VEC3")},
        {"input": times, "output": accessor([0, 0, 0, 1, 0, 0.7071, 0, 0.7071, 0, 1, 0, 0], "VEC4"),
         "interpolation": "STEP"},
        {"input": times, "output": accessor([0, 0, 0, 1, 1, 1, 0, 0, 0] * 3, "VEC3"),
         "interpolation": "CUBICSPLINE"}],
        "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}},
                     {"sampler": 1, "target": {"node": 0, "path": "rotation"}},
                     {"sampler": 2, "target": {"node": 0, "path": "scale"}}]}]


folder = fresh("gltf")
for name, extra in (("triangle", lambda doc, accessor: None), ("materials", materials),
                    ("lights-camera", lights_and_camera), ("animation", animation)):
    doc, data = gltf_document(extra)
    (folder / f"{name}.gltf").write_bytes(embedded(doc, data))
(folder / "animation.glb").write_bytes(glb(*gltf_document(animation)))

for target in sorted(p.name for p in out.iterdir()):
    print(f"{target}: {len(list((out / target).iterdir()))} seeds")
