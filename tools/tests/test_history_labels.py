"""history append keyed by what the user changes: --label, else photonbench's commit and a digest of
the run's plugin builds (run.json "plugins"), so a second append of another label or of a rebuilt
plugin adds an entry instead of replacing the first; each cell's entry holds its plugin's record."""

import json
import os
import unittest

from common import TempRuns

from pbtools import history


def set_plugins(run_dir, plugins):
    path = os.path.join(run_dir, "run.json")
    with open(path, encoding="utf-8") as f:
        info = json.load(f)
    info["plugins"] = plugins
    with open(path, "w", encoding="utf-8") as f:
        json.dump(info, f)


def plugin(technique, digest):
    return {"path": f"/home/me/plugins/{technique}.so", "fnv1a64": digest, "api_version": 5}


class HistoryLabelsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("a", seed=1, images=False)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def setUp(self):
        self.file = self.tmp.path(f"history-{self._testMethodName}.jsonl")

    def test_labels_are_entries_of_their_own(self):
        history.append(self.run_dir, self.file, "radius 0.05")
        _, replaced = history.append(self.run_dir, self.file, "radius 0.1")
        self.assertFalse(replaced)
        self.assertEqual([e["label"] for e in history.load(self.file)], ["radius 0.05", "radius 0.1"])
        _, replaced = history.append(self.run_dir, self.file, "radius 0.1")
        self.assertTrue(replaced)
        self.assertEqual(len(history.load(self.file)), 2)

    def test_a_rebuilt_plugin_is_a_new_entry_and_each_cell_names_its_build(self):
        techniques = {"direct", "tiled", "cluster", "broken"}
        set_plugins(self.run_dir, {t: plugin(t, "00000000000000aa") for t in techniques})
        history.append(self.run_dir, self.file)
        _, replaced = history.append(self.run_dir, self.file)
        self.assertTrue(replaced, "the same build appended twice is one entry")
        set_plugins(self.run_dir, {t: plugin(t, "00000000000000aa" if t != "tiled" else "00000000000000bb")
                               for t in techniques})
        entry, replaced = history.append(self.run_dir, self.file)
        self.assertFalse(replaced, "a rebuilt tiled plugin is a new entry")
        entries = history.load(self.file)
        self.assertEqual(len(entries), 2)
        self.assertNotEqual(entries[0]["label"], entries[1]["label"])
        tiled = next(c for c in entry["cells"].values() if c["technique"] == "tiled")
        self.assertEqual(tiled["plugin"], plugin("tiled", "00000000000000bb"))


if __name__ == "__main__":
    unittest.main()
