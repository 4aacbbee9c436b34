"""Each technique README's parameter table against the technique's schema (`photonbench schema
config`, which the plugins' descriptors generate): the same names, and per name the same type,
default and range (or choices); and its counter table (the first table under '## Counters')
against the counters the descriptor declares (the schema's "x-counters" of the technique): the
same names, each with the same kind and unit. A README's tables are written by hand; this keeps
them the descriptor's. A counter row may name several with braces: `profile_{top,count}_steps`.

    readme_params.py SCHEMA.json SOURCE_DIR     exit 1 naming every disagreement
"""
import json
import math
import pathlib
import re
import sys

TYPES = {"int": "integer", "float": "number", "bool": "boolean", "enum": "string", "string": "string"}


def cells(line: str):
    return [c.strip().strip("`") for c in line.strip().strip("|").split("|")]


def table_rows(text: str, heading: str):
    """The rows of the first table under a heading that starts with `heading`, as lists of cells
    under the header's lower-cased names; None when there is no such heading."""
    lines = text.splitlines()
    start = next((i for i, l in enumerate(lines) if l.startswith(heading)), None)
    if start is None:
        return None
    rows, header = [], None
    for line in lines[start + 1:]:
        if line.startswith("## "):
            break
        if not line.startswith("|"):
            if header is not None and rows:
                break
            continue
        values = cells(line)
        if header is None:
            header = [h.lower() for h in values]
        elif not set(line.replace("|", "").strip()) <= set("-: "):
            rows.append(dict(zip(header, values)))
    return rows


def expand(name: str):
    """`a_{b,c}_{d,e}` -> a_b_d, a_b_e, a_c_d, a_c_e."""
    match = re.search(r"\{([^{}]*)\}", name)
    if not match:
        return [name]
    return [out for part in match.group(1).split(",")
            for out in expand(name[:match.start()] + part.strip() + name[match.end():])]


def counter_table(text: str):
    """{counter: {column: value}} of the README's counter table; None without a '## Counters'
    heading."""
    rows = table_rows(text, "## Counters")
    if rows is None:
        return None
    table = {}
    for row in rows:
        for name in expand(row.get("counter", "").strip("`")):
            table[name] = row
    return table


def check_counters(technique: str, rows: dict, declared: dict) -> list:
    problems = []
    if rows is None:
        return [f"{technique}: the descriptor declares counters but the README has no '## Counters' table"] \
            if declared else []
    for name in sorted(set(declared) - set(rows)):
        problems.append(f"{technique}: counter '{name}' is declared but not in the README's table")
    for name in sorted(set(rows) - set(declared)):
        problems.append(f"{technique}: counter '{name}' is in the README's table but not declared")
    for name in sorted(set(rows) & set(declared)):
        for column in ("kind", "unit"):
            if rows[name].get(column, "") != declared[name][column]:
                problems.append(f"{technique}.{name}: README {column} {rows[name].get(column, '')!r}, "
                                f"descriptor {declared[name][column]!r}")
    return problems


def declared_counters(schema: dict) -> dict:
    """{technique: {counter: {kind, unit, description}}} from the config schema's technique
    entries."""
    out = {}
    for entry in schema["$defs"].get("config.technique", {}).get("anyOf", []):
        technique = entry.get("properties", {}).get("technique", {})
        if "const" in technique:
            out[technique["const"]] = technique.get("x-counters", {})
    return out


def readme_table(text: str):
    """The rows of the first table under a '## Parameters' heading: {name: {column: value}}."""
    table = table_rows(text, "## Parameters")
    if table is None:
        return None
    rows = {}
    for row in table:
        # "`variance_gain` g": the name is the first word; "tile_size, max_list_entries" with
        # the other columns empty names parameters another technique's table describes.
        names = [n.strip().strip("`").split("`")[0].split(" ")[0]
                 for n in row.get("name", row.get("parameter", "")).split(",")]
        for name in names:
            rows[name] = row if len(names) == 1 else {}
    return rows


def number(text: str):
    """A number as a table writes it: 19, 1e-05, 2^24, or followed by a note ("0 (off)", "19 px²")."""
    match = re.match(r"\s*(-?[0-9.]+(?:e[-+]?[0-9]+)?)(?:\^([0-9]+))?", text)
    if not match:
        return None
    value = float(match.group(1))
    return value ** int(match.group(2)) if match.group(2) else value


def same_value(readme: str, schema) -> bool:
    if isinstance(schema, bool):
        return readme.lower() == str(schema).lower()
    if isinstance(schema, (int, float)):
        value = number(readme)
        return value is not None and math.isclose(value, float(schema), rel_tol=1e-9, abs_tol=1e-12)
    return readme == str(schema)


def check(technique: str, rows: dict, properties: dict) -> list:
    problems = []
    for name in sorted(set(properties) - set(rows)):
        problems.append(f"{technique}: '{name}' is in the schema but not in the README's table")
    for name in sorted(set(rows) - set(properties)):
        problems.append(f"{technique}: '{name}' is in the README's table but not in the schema")
    for name in sorted(set(rows) & set(properties)):
        row, prop = rows[name], properties[name]["anyOf"][0] if "anyOf" in properties[name] else properties[name]
        if "default" in row and not same_value(row["default"], prop.get("default")):
            problems.append(f"{technique}.{name}: README default {row['default']!r}, schema {prop.get('default')!r}")
        if "type" in row and TYPES.get(row["type"], row["type"]) != prop.get("type", "string" if "enum" in prop else None):
            problems.append(f"{technique}.{name}: README type {row['type']!r}, schema {prop.get('type')!r}")
        if "range" in row and row["range"] not in ("", "-"):
            if "enum" in prop:
                listed = [v.strip() for v in re.split(r"[|,]", row["range"].replace("\\|", "|")) if v.strip()]
                if listed != [str(v) for v in prop["enum"]]:
                    problems.append(f"{technique}.{name}: README choices {listed}, schema {prop['enum']}")
            elif "minimum" in prop:
                bounds = re.match(r"\[\s*([^,]+),\s*([^\]]+)\]", row["range"])  # a note may follow
                if not bounds or not (same_value(bounds.group(1), prop["minimum"])
                                      and same_value(bounds.group(2), prop["maximum"])):
                    problems.append(f"{technique}.{name}: README range {row['range']!r}, schema "
                                    f"[{prop['minimum']}, {prop['maximum']}]")
    return problems


def main() -> int:
    schema = json.load(open(sys.argv[1]))
    source = pathlib.Path(sys.argv[2])
    problems, checked = [], 0
    counters = declared_counters(schema)
    for key, definition in sorted(schema["$defs"].items()):
        match = re.fullmatch(r"techniques\.(.+)\.params", key)
        if not match:
            continue
        technique = match.group(1)
        readme = source / "techniques" / technique / "README.md"
        if not readme.exists():
            continue  # a plugin from another folder (tests' plugins, --plugin-dir)
        rows = readme_table(readme.read_text(encoding="utf-8"))
        if rows is None:
            problems.append(f"{readme}: no '## Parameters' table")
            continue
        problems += check(technique, rows, definition["properties"])
        problems += check_counters(technique, counter_table(readme.read_text(encoding="utf-8")),
                                   counters.get(technique, {}))
        checked += 1
    for p in problems:
        print(p)
    print(f"{checked} technique READMEs checked, {len(problems)} disagreements")
    return 1 if problems or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
