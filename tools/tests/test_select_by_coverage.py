"""scripts/sanitizers/select_by_coverage.py: reading llvm-profdata's counters and choosing the tests
the sanitized pass may leave out."""
import importlib.util
import pathlib
import unittest

_SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts/sanitizers/select_by_coverage.py"
_spec = importlib.util.spec_from_file_location("select_by_coverage", _SCRIPT)
select_by_coverage = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(select_by_coverage)

# The shape of `llvm-profdata-14 show --all-functions --counts`: counter 0 is the function count,
# the block counts are counters 1.. .
SHOWN = """Counters:
  _ZN2pb5traceA:
    Hash: 0x00000000000000aa
    Counters: 3
    Function count: 5
    Block counts: [0, 7]
  scene.cpp:_ZN2pb12_GLOBAL__N_1B:
    Hash: 0x0000000000000018
    Counters: 1
    Function count: 0
    Block counts: []
  _ZN2pb5traceC:
    Hash: 0x00000000000000bb
    Counters: 1
    Function count: 2
    Block counts: []
Instrumentation level: Front-end
Functions shown: 3
"""


class ExecutedRegions(unittest.TestCase):
    def test_every_non_zero_counter_and_only_those(self):
        self.assertEqual(
            select_by_coverage.executed_regions(SHOWN),
            {("_ZN2pb5traceA#0x00000000000000aa", 0), ("_ZN2pb5traceA#0x00000000000000aa", 2),
             ("_ZN2pb5traceC#0x00000000000000bb", 0)})


class Choose(unittest.TestCase):
    def test_a_test_with_a_region_of_its_own_is_kept(self):
        coverage = {"big": {1, 2, 3}, "small": {1, 2}, "own": {3, 4}}
        left_out = select_by_coverage.choose(coverage, {"big": 10, "small": 1, "own": 5})
        # big (costliest) goes: 1, 2 stay run by small, 3 by own. Then own holds 3 and 4 alone,
        # small 1 and 2 alone.
        self.assertEqual(left_out, ["big"])

    def test_costliest_first_and_never_two_that_only_cover_each_other(self):
        coverage = {"a": {1, 2}, "b": {1, 2}, "c": {2}}
        left_out = select_by_coverage.choose(coverage, {"a": 1, "b": 9, "c": 5})
        self.assertEqual(left_out, ["b", "c"])
        kept = set(coverage) - set(left_out)
        self.assertEqual(set().union(*(coverage[n] for n in kept)), {1, 2})

    def test_a_test_that_runs_nothing_of_ours_is_kept(self):
        self.assertEqual(select_by_coverage.choose({"empty": set(), "x": {1}}, {"empty": 9}), [])


class SanitizedPass(unittest.TestCase):
    def test_the_labels_left_out_are_those_of_scripts_test_sh(self):
        # The script lists the tests of the pass by the same -LE as the pass itself; with another,
        # it would choose among tests the pass does not run, or miss some it does.
        test_sh = (_SCRIPT.parents[1] / "test.sh").read_text()
        self.assertIn(f"set -- -LE '{select_by_coverage.SANITIZED_PASS_EXCLUDES}'", test_sh)


if __name__ == "__main__":
    unittest.main()
