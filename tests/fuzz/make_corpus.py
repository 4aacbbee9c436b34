#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora (tests/fuzz/corpus/<target>/) from the shipped files.

config: every configs/*.yaml; scene: every scenes/*.yaml and the test scenes; obj: every OBJ file
under scenes/ and tests/data/scenes/ with the MTL file it names, as "OBJ \\0 MTL" (fuzz_obj.cpp);
set: each shipped config's settings written as --set lines ("frames.count=32", one per line).
Run it again when those files change; scripts/fuzz.sh copies the seeds into build-fuzz/ and
fuzzes from there, so what the fuzzers find never lands here unasked.
"""
import pathlib
import re
import shutil

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

for target in sorted(p.name for p in out.iterdir()):
    print(f"{target}: {len(list((out / target).iterdir()))} seeds")
