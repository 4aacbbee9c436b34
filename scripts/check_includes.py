#!/usr/bin/python3
"""The include graph of harness/src, folder by folder, checked against the layers of a run
(docs/architecture.md, "Include graph"): a folder may include its own headers and those of folders
below it, never those of a folder above; inside a folder, its modules (a header with its .cpp) form
no cycle. Prints the graph; exits 1 naming each include that goes up and each cycle.

    scripts/check_includes.py [--quiet] [--floors]

--floors also prints each folder's modules by floor (the include graph inside the folder).
"""
import pathlib
import re
import sys

# Top to bottom: the order in which a run calls them. `photonbench` is the public plugin API
# (harness/include/photonbench) with the GPU layouts it shares with GLSL (harness/shaders).
# A run (run/) spawns cells; a cell (cell/) plays a plan's cell (plan/) through its plugin; the
# reference renderer (reference/) is built on the tracing services (trace/).
LAYERS = ["cli", "run", "cell", "plan", "gpu", "reference", "trace", "metrics", "scene", "config", "io",
          "photonbench"]
# Cycles inside a folder that are known and not yet broken, each with what breaks it; any other
# cycle fails the check, and so does a listed one that is gone (so the list stays true).
KNOWN_CYCLES: dict[tuple[str, ...], str] = {}
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


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def floors(modules: dict[str, set[str]], folder: str) -> list[list[str]]:
    """The modules of one folder by floor: floor 0 includes none of its folder's modules, floor n
    includes one of floor n - 1 at most (the longest chain below it). Assumes no cycle."""
    own = sorted({m for m in modules if m.startswith(folder + "/")} |
                 {d for deps in modules.values() for d in deps if d.startswith(folder + "/")})
    depth: dict[str, int] = {}

    def floor_of(module: str, seen: tuple[str, ...] = ()) -> int:
        if module not in depth:
            below = [d for d in modules.get(module, ()) if d not in seen]
            depth[module] = 1 + max((floor_of(d, seen + (module,)) for d in below), default=-1)
        return depth[module]

    by_floor: dict[int, list[str]] = {}
    for module in own:
        by_floor.setdefault(floor_of(module), []).append(module.split("/", 1)[1])
    return [by_floor[n] for n in sorted(by_floor)]


def main() -> int:
    root = pathlib.Path(__file__).resolve().parent.parent
    src = root / "harness" / "src"
    edges: dict[str, set[str]] = {}
    # Inside a folder: module (folder/stem, a header and its .cpp together) -> modules it includes.
    modules: dict[str, set[str]] = {}
    upward = []
    for source in sorted(src.rglob("*")):
        if source.suffix not in (".h", ".cpp"):
            continue
        folder = source.relative_to(src).parts[0]
        if folder not in LAYERS:
            upward.append(f"{source.relative_to(root)}: folder '{folder}' has no layer")
            continue
        modules.setdefault(source.relative_to(src).with_suffix("").as_posix(), set())
        for number, line in enumerate(source.read_text(encoding="utf-8").splitlines(), 1):
            match = INCLUDE.match(line)
            if not match:
                continue
            target = target_folder(source, match.group(1), src)
            if target == folder:
                included = (src / match.group(1)) if "/" in match.group(1) else source.parent / match.group(1)
                if included.exists() and included.resolve().is_relative_to(src):
                    name = included.resolve().relative_to(src).with_suffix("").as_posix()
                    own = source.relative_to(src).with_suffix("").as_posix()
                    if name != own:
                        modules.setdefault(own, set()).add(name)
                continue
            edges.setdefault(folder, set()).add(target)
            if target not in LAYERS or LAYERS.index(target) < LAYERS.index(folder):
                upward.append(f"{source.relative_to(root)}:{number}: {folder} includes "
                              f"{match.group(1)} ({target} is not below {folder})")
    if "--quiet" not in sys.argv:
        for folder in LAYERS:
            below = sorted(edges.get(folder, ()), key=lambda t: LAYERS.index(t) if t in LAYERS else 99)
            print(f"{folder:12s} -> {', '.join(below) if below else '(nothing)'}")
        if "--floors" in sys.argv:
            for folder in LAYERS:
                for number, names in reversed(list(enumerate(floors(modules, folder)))):
                    print(f"  {folder}/ floor {number}: {' '.join(names)}")
    found = cycles(modules)
    for component in found:
        if tuple(component) not in KNOWN_CYCLES:
            upward.append(f"harness/src: include cycle among {', '.join(component)}")
    for component, why in KNOWN_CYCLES.items():
        if list(component) not in found:
            upward.append(f"scripts/check_includes.py: the known cycle {', '.join(component)} is gone: "
                          "take it off KNOWN_CYCLES")
        elif "--quiet" not in sys.argv:
            print(f"known cycle: {', '.join(component)} ({why})")
    for line in upward:
        print(line, file=sys.stderr)
    return 1 if upward else 0


if __name__ == "__main__":
    sys.exit(main())
