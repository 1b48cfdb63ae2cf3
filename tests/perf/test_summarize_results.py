#!/usr/bin/env python3
"""perf/summarize_results.py on the tiny `pliant bench --csv` fixtures of tests/data/compare_bench/
(three runs of the "new" version): it must not fail on records that leave columns empty (a
multiresolution scene has no roofline; a skipped scene has no time), and its medians and ranges
are checked against figures worked out by hand from the fixtures. No timing.

    python3 tests/perf/test_summarize_results.py [SOURCE_DIR]
"""
import os
import subprocess
import sys
import unittest

SOURCE = os.path.abspath(sys.argv.pop(1) if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
SCRIPT = os.path.join(SOURCE, "perf", "summarize_results.py")
DATA = os.path.join(SOURCE, "tests", "data", "compare_bench")


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


class SummarizeResults(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        runs = [os.path.join(DATA, f"new-run{i}.csv") for i in (1, 2, 3)]
        for f in runs:
            if not os.path.exists(f):
                raise unittest.SkipTest(f"fixture {f} is missing")
        p = subprocess.run([sys.executable, SCRIPT, *runs], capture_output=True, text=True)
        cls.rc, cls.out, cls.err = p.returncode, p.stdout, p.stderr
        cls.rows = {}
        for line in cls.out.splitlines():
            if line.startswith("| ") and not line.startswith("| case") and not line.startswith("|---"):
                c = cells(line)
                cls.rows.setdefault((c[0], c[2], c[5]), c)

    def test_runs_to_the_end(self):
        self.assertEqual(self.rc, 0, self.err)
        self.assertIn("Medians over 3 run(s).", self.out)
        self.assertIn("| machine | precision | threads | MiB | median | min..max |", self.out)

    def test_a_scene_without_roofline_leaves_those_cells_empty(self):
        # scene/multires_organ/staggered, 1 thread: ns/tet 3.0 in every run (and a p50, no p99).
        row = self.rows[("scene/multires_organ/staggered", "float", "1")]
        self.assertEqual(row[6], "3.00")
        self.assertEqual(row[7], "3.00..3.00")
        self.assertEqual(row[8], "")   # B/tet
        self.assertEqual(row[10], "")  # roofline
        self.assertEqual(row[12], "")  # p99

    def test_the_scene_table_gives_medians_and_ranges(self):
        # scene/default, 2 threads: step p50 25, 20, 30 us and real-time factor 4.0, 4.2, 3.8 in the three runs.
        line = next(l for l in self.out.splitlines() if l.startswith("| default | float | 3863 | 2 |"))
        c = cells(line)
        self.assertEqual(c[5], "25.0 (20.0..30.0)")
        self.assertEqual(c[8], "4.00 (3.80..4.20)")

    def test_a_skipped_scene_gives_its_note(self):
        row = self.rows[("scene/cantilever", "", "1")]
        self.assertIn("skipped", row[6])


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
