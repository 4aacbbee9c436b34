"""Validates YAML files against a JSON Schema with python3-jsonschema (draft 2020-12).

usage: schema_check.py SCHEMA.json FILE...
Prints "FILE: ok" or each error with its key path; exits 0 when every file is valid, 1 when one is
not (or is not YAML), 3 when the schema or the checker itself is broken.
The YAML is read as photonbench's reader (yaml-cpp) reads it: 1e23 is a number (PyYAML's YAML 1.1
resolver wants a dot in it), and a key written twice is an error (PyYAML keeps the last one).
"""
import json
import re
import sys

import jsonschema
import yaml


class Loader(yaml.SafeLoader):
    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} is written twice", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, Loader.construct_mapping)
Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)[eE][-+]?[0-9]+$"), list("-+.0123456789"))


def main():
    schema = json.load(open(sys.argv[1]))
    validator = jsonschema.Draft202012Validator(schema)
    invalid = 0
    for path in sys.argv[2:]:
        try:
            with open(path, "rb") as f:
                document = yaml.load(f.read().decode("utf-8"), Loader=Loader)
        except (yaml.YAMLError, UnicodeDecodeError) as e:
            print(f"{path}: not YAML: {str(e).splitlines()[0]}")
            invalid += 1
            continue
        errors = sorted(validator.iter_errors(document), key=lambda e: list(e.absolute_path))
        for error in errors:
            where = ".".join(str(p) for p in error.absolute_path) or "(root)"
            print(f"{path}: {where}: {error.message[:200]}")
        if errors:
            invalid += 1
        else:
            print(f"{path}: ok")
    sys.exit(1 if invalid else 0)


try:
    main()
except Exception as e:  # a broken schema or checker is not a rejected file: exit 3, not 1
    print(f"schema_check: {type(e).__name__}: {e}")
    sys.exit(3)
