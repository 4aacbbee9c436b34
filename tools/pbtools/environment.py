"""What a run's times depend on besides the code: the machine, the Vulkan driver and the build type, as
its run.json records them. `history` marks an entry whose environment differs from the previous
entry's, and `compare` warns when its two sides differ: a time measured on another CPU, another Mesa or
a Debug build is not a regression of the code.

  machine  run.json "cpu" (model), "cpu_count", and the vector width lavapipe compiles its shaders to
           (the "N bits" in llvmpipe's device name: 256 for AVX2, 512 for AVX-512)
  driver   run.json "driver" (e.g. "llvmpipe Mesa 22.3.6 (LLVM 15.0.6)"), else "device"
  build    run.json "build_type", or "build": {"type" | "build_type"}, or "ndebug" (true: a Release-like
           build): whichever the harness records

A field a run does not record is None and never counts as a difference (old history entries predate
some of them).
"""

from __future__ import annotations

import re
from typing import Dict, List, Optional, Tuple

FIELDS = ("machine", "driver", "build")


def _build_type(info: dict) -> Optional[str]:
    if info.get("build_type"):
        return str(info["build_type"])
    build = info.get("build")
    if isinstance(build, dict):
        for key in ("type", "build_type"):
            if build.get(key):
                return str(build[key])
        if "ndebug" in build:
            return "NDEBUG" if build["ndebug"] else "assertions on (no NDEBUG)"
    elif isinstance(build, str) and build:
        return build
    if "ndebug" in info:
        return "NDEBUG" if info["ndebug"] else "assertions on (no NDEBUG)"
    return None


def _device_name(info: dict) -> str:
    d = info.get("device")
    if isinstance(d, dict):
        return str(d.get("name", ""))
    return str(d or "")


def _machine(info: dict) -> Optional[str]:
    parts = []
    if info.get("cpu"):
        parts.append(str(info["cpu"]))
    if info.get("cpu_count"):
        parts.append(f"{info['cpu_count']} CPUs")
    m = re.search(r"(\d+) bits", _device_name(info))
    if m:
        parts.append(f"{m.group(1)}-bit vectors")
    return ", ".join(parts) or None


def of(info: dict) -> Dict[str, Optional[str]]:
    """{machine, driver, build} of a run.json (see the module docstring); None where not recorded."""
    return {"machine": _machine(info), "driver": str(info.get("driver") or _device_name(info) or "") or None,
            "build": _build_type(info)}


def differences(a: Optional[dict], b: Optional[dict]) -> List[Tuple[str, str, str]]:
    """(field, a's value, b's value) for each field both record and that differs."""
    a, b = a or {}, b or {}
    return [(f, a[f], b[f]) for f in FIELDS if a.get(f) and b.get(f) and a[f] != b[f]]


def describe(diffs: List[Tuple[str, str, str]]) -> str:
    """'machine AMD EPYC, 2 CPUs -> Intel Xeon, 4 CPUs; build Release -> Debug'."""
    return "; ".join(f"{field} {x} -> {y}" for field, x, y in diffs)
