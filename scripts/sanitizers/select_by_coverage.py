#!/usr/bin/env python3
"""Which tests the sanitized pass may leave out: those whose code is all run by the tests it keeps.

The sanitizers can only report on code that runs under them. A test whose every executed region of
our code (the harness library, the toolkit, the plugins, the executable) is also executed by a test
the sanitized pass keeps runs nothing there that the sanitizers would not already see; it still
runs in the Release pass, where its assertions are checked. This script measures that with Clang's
source-based coverage, one profile per test:

  1. builds DIR (default build-coverage/) with clang-14 and -fprofile-instr-generate
     -fcoverage-mapping, as scripts/test.sh --sanitize builds build-asan/ but without the
     sanitizers (the same tests, one process per GoogleTest suite);
  2. runs each test of the sanitized pass (`-LE 'statistical|python'`) alone, its processes
     writing their profiles into a folder of its own (every photonbench process an end-to-end
     script starts, and every plugin module, included);
  3. merges each test's profiles and reads which counters are non-zero: a counter is one region of
     a function (a block between branches), so this is region coverage, finer than lines. Only
     our code under test counts (our_code() says which): the code of ours a test file compiles
     in (a header's inline functions, our templates) does;
  4. leaves out tests, longest first (their sanitized times from --costs, CTest's cost file of a
     sanitized run), while every region a left-out test runs is still run by some kept test.

It writes the left-out tests to OUT (default scripts/sanitizers/covered_elsewhere.txt), one name a
line under a header that says when, from which commit and what the choice saved, and prints each
decision. scripts/test.sh --sanitize reads that file. A test added later is not in it, so it runs;
run this again after a change that moves code between tests' reach.

Region coverage is not input coverage: a left-out test may run the same regions with other sizes or
data (an off-by-one that only one size reaches). The pass keeps every test with a region of its
own, and every test still runs unsanitized.

  scripts/sanitizers/select_by_coverage.py --costs build-asan/Testing/Temporary/CTestCostData.txt
"""
import argparse
import concurrent.futures
import datetime
import hashlib
import os
import pathlib
import re
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
# scripts/test.sh --sanitize's -LE (tools/tests/test_select_by_coverage.py checks they agree).
SANITIZED_PASS_EXCLUDES = "statistical|python"


def configure_and_build(build: pathlib.Path) -> None:
    flags = "-fprofile-instr-generate -fcoverage-mapping"
    link = "-fprofile-instr-generate"
    subprocess.run(
        ["cmake", "-S", str(ROOT), "-B", str(build), "-G", "Ninja",
         "-DCMAKE_C_COMPILER=clang-14", "-DCMAKE_CXX_COMPILER=clang++-14",
         "-DCMAKE_BUILD_TYPE=RelWithDebInfo", "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -DNDEBUG",
         f"-DCMAKE_CXX_FLAGS={flags}", f"-DCMAKE_EXE_LINKER_FLAGS={link}",
         f"-DCMAKE_SHARED_LINKER_FLAGS={link}", f"-DCMAKE_MODULE_LINKER_FLAGS={link}",
         "-C", str(ROOT / "scripts/sanitizers/tests.cmake")],
        check=True, stdout=subprocess.DEVNULL)
    subprocess.run(["cmake", "--build", str(build), "-j", str(os.cpu_count())], check=True)


def sanitized_pass_tests(build: pathlib.Path) -> list[str]:
    listing = subprocess.run(["ctest", "-N", "-LE", SANITIZED_PASS_EXCLUDES], cwd=build,
                             check=True, capture_output=True, text=True).stdout
    # A value-parameterised test's name goes on with "  # GetParam() = ...".
    return re.findall(r"^\s*Test\s+#\d+: (.+)$", listing, re.M)


def name_regex(name: str) -> str:
    return "^" + re.escape(name) + "$"


def run_one(build: pathlib.Path, profiles: pathlib.Path, name: str, reuse: bool):
    folder = profiles / hashlib.sha1(name.encode()).hexdigest()[:16]
    merged = folder / "merged.profdata"
    if reuse:
        if not merged.exists():
            return name, 1, 0.0, set()
        return name, 0, 0.0, read_profile(merged)
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    # %p: one file per process; %m: one per instrumented module, since every plugin carries its
    # own profile runtime.
    env = dict(os.environ, LLVM_PROFILE_FILE=str(folder / "%p-%m.profraw"))
    started = datetime.datetime.now()
    result = subprocess.run(["ctest", "-R", name_regex(name), "--timeout", "900"], cwd=build,
                            env=env, capture_output=True, text=True)
    seconds = (datetime.datetime.now() - started).total_seconds()
    raw = sorted(folder.glob("*.profraw"))
    regions: set[tuple[str, int]] = set()
    if raw:
        subprocess.run(["llvm-profdata-14", "merge", "-sparse", "-o", str(merged)]
                       + [str(p) for p in raw], check=True)
        regions = read_profile(merged)
        for p in raw:
            p.unlink()
    return name, result.returncode, seconds, regions


def read_profile(merged: pathlib.Path) -> set[tuple[str, int]]:
    shown = subprocess.run(["llvm-profdata-14", "show", "--all-functions", "--counts", str(merged)],
                           check=True, capture_output=True, text=True).stdout
    return executed_regions(shown)


def executed_regions(shown: str) -> set[tuple[str, int]]:
    """(function, counter index) for every non-zero counter of `llvm-profdata show --counts`."""
    regions = set()
    function = None
    for line in shown.splitlines():
        if line.startswith("  ") and not line.startswith("    ") and line.rstrip().endswith(":"):
            function = line.strip()[:-1]
        elif function and line.strip().startswith("Hash:"):
            function = function + "#" + line.split(":", 1)[1].strip()
        elif function and line.strip().startswith("Function count:"):
            # Counter 0, the function's entry.
            if int(line.split(":", 1)[1]) > 0:
                regions.add((function, 0))
        elif function and line.strip().startswith("Block counts:"):
            counts = line.split(":", 1)[1].strip().strip("[]")
            for i, value in enumerate(counts.split(",") if counts else [], 1):
                if int(value) > 0:
                    regions.add((function, i))
    return regions


def our_code(build: pathlib.Path, profiles: pathlib.Path) -> set[str]:
    """The functions of our code under test: those whose coverage mapping (llvm-cov's lcov export
    of every instrumented binary: each function under its file) puts them in the source tree
    outside tests/ and techniques/*/tests/. Not counted: the test bodies, fixtures, helpers and
    test plugins, where every test has code of its own, and the standard library's and
    GoogleTest's templates instantiated for a test's own types (Clang maps no system header, so
    they are in no file)."""
    merged = profiles / "all.profdata"
    subprocess.run(["llvm-profdata-14", "merge", "-sparse", "-o", str(merged)]
                   + [str(p) for p in profiles.glob("*/merged.profdata")], check=True)
    # (test-plugins/ also holds not_a_module.so, which is not a shared object at all.)
    candidates = [build / "photonbench", build / "tests/photonbench_tests"] \
        + sorted(build.glob("lib*.so")) + sorted(build.glob("plugins/*.so")) \
        + sorted(build.glob("test-plugins/*.so"))
    objects = [p for p in candidates if p.is_file() and p.read_bytes()[:4] == b"\x7fELF"]
    command = ["llvm-cov-14", "export", "-format=lcov", "-skip-expansions",
               f"-instr-profile={merged}", str(objects[0])]
    for extra in objects[1:]:
        command += ["-object", str(extra)]
    lcov = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    root = str(ROOT) + "/"
    test_file = re.compile(r"^tests/|^techniques/[^/]+/tests/")
    functions, ours = set(), False
    for line in lcov.splitlines():
        if line.startswith("SF:"):
            path = os.path.normpath(line[3:])
            ours = path.startswith(root) and not test_file.search(path[len(root):])
        elif ours and line.startswith("FN:"):
            functions.add(line.split(",", 1)[1])
    return functions


def read_costs(path: pathlib.Path | None) -> dict[str, float]:
    costs = {}
    if path:
        for line in path.read_text().splitlines():
            parts = line.rsplit(maxsplit=2)  # name (spaces and all), runs, seconds
            if len(parts) == 3:
                costs[parts[0]] = float(parts[2])
    return costs


def choose(coverage: dict[str, set], costs: dict[str, float]):
    """Greedy: the costliest test first, left out while each of its regions stays run by another."""
    runs = {}
    for regions in coverage.values():
        for region in regions:
            runs[region] = runs.get(region, 0) + 1
    left_out = []
    for name in sorted(coverage, key=lambda n: -costs.get(n, 0.0)):
        regions = coverage[name]
        if regions and all(runs[r] >= 2 for r in regions):
            for r in regions:
                runs[r] -= 1
            left_out.append(name)
    return left_out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", type=pathlib.Path, default=ROOT / "build-coverage")
    parser.add_argument("--costs", type=pathlib.Path,
                        help="CTest's cost file of a sanitized run (build-asan/Testing/Temporary/"
                             "CTestCostData.txt): which tests are worth leaving out first")
    parser.add_argument("--out", type=pathlib.Path,
                        default=ROOT / "scripts/sanitizers/covered_elsewhere.txt")
    parser.add_argument("--no-build", action="store_true", help="DIR is built already")
    parser.add_argument("--no-run", action="store_true",
                        help="choose again from the profiles of an earlier run in DIR")
    args = parser.parse_args()

    if not args.no_build:
        configure_and_build(args.build)
    tests = sanitized_pass_tests(args.build)
    costs = read_costs(args.costs)
    profiles = args.build / "coverage-profiles"
    coverage: dict[str, set] = {}
    failed = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count()) as pool:
        jobs = [pool.submit(run_one, args.build, profiles, name, args.no_run) for name in tests]
        for done, job in enumerate(concurrent.futures.as_completed(jobs), 1):
            name, code, seconds, regions = job.result()
            print(f"[{done}/{len(tests)}] {name}: {len(regions)} regions, {seconds:.1f} s"
                  + ("" if code == 0 else f", FAILED (ctest exit {code})"), flush=True)
            if code != 0:
                failed.append(name)
            coverage[name] = regions
    if failed:
        # A failing test's profile is cut short: choosing from it could drop a test that matters.
        print("not choosing: these tests failed under coverage: " + ", ".join(failed),
              file=sys.stderr)
        return 1
    ours = our_code(args.build, profiles)
    print(f"{len(ours)} functions of our code under test", flush=True)
    coverage = {name: {r for r in regions if r[0].split("#")[0] in ours}
                for name, regions in coverage.items()}

    left_out = choose(coverage, costs)
    kept = [n for n in tests if n not in left_out]
    union = set().union(*coverage.values())
    kept_union = set().union(*(coverage[n] for n in kept))
    assert kept_union == union, "a left-out test had a region no kept test runs"
    saved = sum(costs.get(n, 0.0) for n in left_out)
    total = sum(costs.get(n, 0.0) for n in tests)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    header = [
        "# Tests the sanitized pass leaves out (scripts/test.sh --sanitize): every region of our",
        "# code each runs is run by a test the pass keeps.",
        "# Made by scripts/sanitizers/select_by_coverage.py",
        f"# on {datetime.date.today()} at commit {commit}: of {len(tests)} tests,",
        f"# executing {len(union)} regions of our code, {len(left_out)} left out:",
        f"# {saved:.0f} of {total:.0f} test-seconds of the sanitized pass",
        "# (CTest's times of a sanitized run).",
    ]
    args.out.write_text("\n".join(header + sorted(left_out)) + "\n")
    for name in left_out:
        print(f"left out: {name} ({costs.get(name, 0.0):.1f} s sanitized, "
              f"{len(coverage[name])} regions)")
    print(f"{len(left_out)} of {len(tests)} left out, {saved:.0f} of {total:.0f} s; "
          f"written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
