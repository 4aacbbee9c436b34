#!/usr/bin/python3
"""The include graph of harness/src, folder by folder, checked against the layers of a run
(docs/architecture.md, "Include graph"): a folder may include its own headers and those of folders
below it, never those of a folder above. Prints the graph; exits 1 naming each include that goes up.

    scripts/check_includes.py [--quiet]
"""
import pathlib
import re
import sys

# Top to bottom: the order in which a run calls them. `photonbench` is the public plugin API
# (harness/include/photonbench) with the GPU layouts it shares with GLSL (harness/shaders).
LAYERS = ["cli", "run", "gpu", "trace", "metrics", "scene", "config", "io", "photonbench"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def target_folder(source: pathlib.Path, include: str, src: pathlib.Path) -> str:
    """The layer an include names: its first path part, or for a relative path the folder it
    resolves to (harness/shaders counts as the public layer)."""
    if include.startswith("."):
        resolved = (source.parent / include).resolve()
        if resolved.is_relative_to(src):
            return resolved.relative_to(src).parts[0]
        return "photonbench" if resolved.parent.name == "shaders" else f"outside:{include}"
    return include.split("/")[0] if "/" in include else source.parent.name


def main() -> int:
    root = pathlib.Path(__file__).resolve().parent.parent
    src = root / "harness" / "src"
    edges: dict[str, set[str]] = {}
    upward = []
    for source in sorted(src.rglob("*")):
        if source.suffix not in (".h", ".cpp"):
            continue
        folder = source.relative_to(src).parts[0]
        if folder not in LAYERS:
            upward.append(f"{source.relative_to(root)}: folder '{folder}' has no layer")
            continue
        for number, line in enumerate(source.read_text(encoding="utf-8").splitlines(), 1):
            match = INCLUDE.match(line)
            if not match:
                continue
            target = target_folder(source, match.group(1), src)
            if target == folder:
                continue
            edges.setdefault(folder, set()).add(target)
            if target not in LAYERS or LAYERS.index(target) < LAYERS.index(folder):
                upward.append(f"{source.relative_to(root)}:{number}: {folder} includes "
                              f"{match.group(1)} ({target} is not below {folder})")
    if "--quiet" not in sys.argv:
        for folder in LAYERS:
            below = sorted(edges.get(folder, ()), key=lambda t: LAYERS.index(t) if t in LAYERS else 99)
            print(f"{folder:12s} -> {', '.join(below) if below else '(nothing)'}")
    for line in upward:
        print(line, file=sys.stderr)
    return 1 if upward else 0


if __name__ == "__main__":
    sys.exit(main())
