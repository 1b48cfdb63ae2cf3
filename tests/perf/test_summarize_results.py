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
import tempfile
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
        self.assertEqual(c[7], "")  # floor p99: these CSVs are from before the column
        self.assertEqual(c[9], "4.00 (3.80..4.20)")

    def test_the_scene_table_gives_the_median_floor(self):
        # Two runs of a bench CSV with the floor column: step p99 54.6 and 60.0, floor 50.4 and 41.0.
        header = ("case,kind,model,precision,order,size,tets,nodes,threads,ns_per_tet,mtets_per_s,bytes_per_tet,gb_per_s,"
                  "flops_per_tet,gflop_per_s,footprint_mib,roof_gb_per_s,roof_gflop_per_s,roof_ns_per_tet,roofline_fraction,"
                  "bound,steps_per_s,step_p50_us,step_p99_us,step_max_us,realtime_factor,samples,others_busy,value,unit,note,"
                  "round_trip_ns,floor_p99_us")
        paths = []
        with tempfile.TemporaryDirectory() as d:
            for i, (p99, floor) in enumerate([(54.6, 50.4), (60.0, 41.0)]):
                path = os.path.join(d, f"run{i}.csv")
                with open(path, "w") as f:
                    f.write(header + "\n")
                    f.write(f"scene/box2k,scene,corotational,float,,,2016,525,2,13.2,,,,,,,,,,,,37000,27.0,{p99},140,16.0,10000,0,,,,130,{floor}\n")
                paths.append(path)
            p = subprocess.run([sys.executable, SCRIPT, *paths], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        line = next(l for l in p.stdout.splitlines() if l.startswith("| box2k | float | 2016 | 2 |"))
        c = cells(line)
        self.assertEqual(c[6], "57.3")  # p99
        self.assertEqual(c[7], "45.7")  # floor p99

    def test_a_skipped_scene_gives_its_note(self):
        row = self.rows[("scene/cantilever", "", "1")]
        self.assertIn("skipped", row[6])


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]], verbosity=2)
