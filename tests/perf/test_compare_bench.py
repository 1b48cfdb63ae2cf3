#!/usr/bin/env python3
"""perf/compare_bench.py on tiny `pliant bench --csv` fixtures (tests/data/compare_bench/): record
matching across versions, medians, ranges, speed-ups and what is reported unmatched. No timing.

    python3 tests/perf/test_compare_bench.py [SOURCE_DIR]

The fixtures: three runs of an "old" version in the column order of c1dbd21's `pliant bench`, and
three of a "new" one with the columns in another order and one column more. The expected figures
below are worked out by hand from the fixtures' numbers (listed beside each check).
"""
import os
import subprocess
import sys
import tempfile
import unittest

SOURCE = os.path.abspath(sys.argv.pop(1) if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
SCRIPT = os.path.join(SOURCE, "perf", "compare_bench.py")
DATA = os.path.join(SOURCE, "tests", "data", "compare_bench")


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


def cells(line):
    return [c.strip() for c in line.strip().strip("|").split("|")]


class CompareBench(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        for f in ("old-run1.csv", "new-run1.csv"):
            if not os.path.exists(os.path.join(DATA, f)):
                raise unittest.SkipTest(f"fixture {os.path.join(DATA, f)} is missing")
        old = [os.path.join(DATA, f"old-run{i}.csv") for i in (1, 2, 3)]
        new = [os.path.join(DATA, f"new-run{i}.csv") for i in (1, 2, 3)]
        p = run("--old", *old, "--new", *new, "--old-label", "c1dbd21", "--new-label", "abc1234",
                "--machine", "Fixture CPU", "--date", "2026-01-01 00:00 UTC", "--note", "a note from the script", "--scene-differs", "default")
        if p.returncode != 0:
            raise AssertionError(f"compare_bench.py failed ({p.returncode}): {p.stderr}")
        cls.out = p.stdout
        cls.lines = p.stdout.splitlines()

    def section(self, title):
        """The table rows of the section whose heading starts with `title`."""
        start = next(i for i, l in enumerate(self.lines) if l.startswith("## " + title))
        rows = []
        for l in self.lines[start + 1:]:
            if l.startswith("## "):
                break
            if l.startswith("|") and not l.startswith("|---"):
                rows.append(cells(l))
        return rows[0], rows[1:]  # header, rows

    def row(self, title, **match):
        header, rows = self.section(title)
        found = [dict(zip(header, r)) for r in rows if all(dict(zip(header, r)).get(k) == v for k, v in match.items())]
        self.assertEqual(len(found), 1, f"{match} in section {title!r}: {found}\n{self.out}")
        return found[0]

    def test_header_states_machine_date_commits_and_load(self):
        self.assertIn("c1dbd21 (old) against abc1234 (new)", self.out)
        self.assertIn("- **Machine**: Fixture CPU", self.out)
        self.assertIn("- **Date**: 2026-01-01 00:00 UTC", self.out)
        self.assertIn("- **Note**: a note from the script", self.out)
        self.assertIn("- **Note**: scenes/default.json differs between c1dbd21 and abc1234: the scene/default records "
                      "compare different scenes", self.out)
        # others_busy of the timed records: old 0.01 0.01 0.0 0.01 | 0.02 0.01 0.0 | 0.05 0.01 0.0 -> max 0.05;
        # new max 0.3 (step 10k float 1T, run 2).
        self.assertIn("(max 0.05)", self.out)
        self.assertIn("(max 0.30)", self.out)

    def test_whole_step_medians_ranges_and_speedup(self):
        # old 30, 28, 35 -> median 30; new 14, 15, 12 -> 14; 30 / 14 = 2.14;
        # paired 30/14 = 2.14, 28/15 = 1.87, 35/12 = 2.92. new-run3 repeats this record with 99 ns/tet:
        # the first is kept (else the new median would be 15 and the range 12..99).
        r = self.row("Whole corotational step", tets="10k (10752)", precision="float", threads="1")
        self.assertEqual((r["old median"], r["old range"]), ("30.0", "28.0..35.0"))
        self.assertEqual((r["new median"], r["new range"]), ("14.0", "12.0..15.0"))
        self.assertEqual(r["speed-up"], "2.14×")
        self.assertEqual(r["paired"], "1.87..2.92")
        self.assertEqual(r["others busy (max)"], "0.30")
        self.assertEqual(r["target"], "**met**")

    def test_whole_step_below_target_is_missed(self):
        # old 20, 22, 21 -> 21; new 12, 11, 13 -> 12; 21 / 12 = 1.75 < 2; paired 1.67, 2.00, 1.62.
        r = self.row("Whole corotational step", tets="10k (10752)", precision="double", threads="2")
        self.assertEqual((r["old median"], r["new median"], r["speed-up"]), ("21.0", "12.0", "1.75×"))
        self.assertEqual(r["paired"], "1.62..2.00")
        self.assertEqual(r["target"], "missed")

    def test_sizes_outside_the_target_are_not_judged(self):
        r = self.row("Whole corotational step", tets="1k (1152)", precision="float", threads="1")
        self.assertEqual((r["speed-up"], r["target"]), ("2.00×", ""))

    def test_absent_target_cases_are_listed(self):
        self.assertIn("Target cases not in both sets of runs: 10k float 2T, 10k double 1T, 100k float 1T", self.out)
        self.assertIn("1M double 2T (the quick set has no 100k or 1M whole step)", self.out)

    def test_scene_step_time_and_realtime_factor(self):
        # p50 us: old 50, 60, 55 -> 55; new 25, 20, 30 -> 25; 55 / 25 = 2.2; real-time factor 1.9 -> 4.0.
        r = self.row("Scenes", scene="default", precision="float", threads="2")
        self.assertEqual((r["old median"], r["old range"], r["new median"], r["new range"]),
                         ("55.0", "50.0..60.0", "25.0", "20.0..30.0"))
        self.assertEqual(r["speed-up"], "2.20×")
        self.assertEqual(r["real-time factor old → new"], "1.90 → 4.00")
        self.assertEqual(r["note"], "another scene file (see the header)")

    def test_a_skipped_case_matches_loosely_and_shows_why(self):
        # The new cantilever record is a skip: no model or precision, only the note.
        r = self.row("Scenes", scene="cantilever", threads="1")
        self.assertEqual((r["precision"], r["old median"], r["new median"], r["speed-up"]), ("double", "100", "", ""))
        self.assertEqual(r["note"], "new: skipped: scenes/ not found (give --scenes DIR)")

    def test_a_scene_on_another_mesh_is_flagged_with_its_per_tet_times(self):
        # scene/beam: 3840 tets old, 3200 new; p50 100 -> 80 us (1.25x); per tet 26.0 -> 25.0 ns (1.04x).
        r = self.row("Scenes", scene="beam", threads="1")
        self.assertEqual((r["tets old / new"], r["speed-up"], r["note"]),
                         ("3840 / 3200", "1.25×", "different meshes (see the notes)"))
        self.assertIn("scene/beam, corotational, double, 1 thread(s): 3840 tets in the old runs, 3200 in the new: "
                      "different meshes, so its step times compare different work; per tet, 26.0 ns against 25.0 (1.04×)",
                      self.out)

    def test_passes_and_orders(self):
        # element: old 9.0, 9.5, 8.5 -> 9.00; new 4.5, 5.0, 4.0 -> 4.50; 2.00x.
        r = self.row("Passes", **{"pass": "element", "precision": "float", "size": "10k", "threads": "1"})
        self.assertEqual((r["old median"], r["new median"], r["speed-up"]), ("9.00", "4.50", "2.00×"))
        # order/gather: old 8, 9, 10 -> 9; new 4, 4, 5 -> 4; 2.25x; paired 2.00, 2.25, 2.00.
        r = self.row("Memory orders", **{"pass": "order/gather"})
        self.assertEqual((r["old median"], r["new median"], r["speed-up"], r["paired"]),
                         ("9.00", "4.00", "2.25×", "2.00..2.25"))

    def test_machine_limits_matched_per_working_set(self):
        # triad 256 MiB: old 37, 36, 38 -> 37; new 40, 36, 38 -> 38; 38 / 37 = 1.03.
        r = self.row("The machine's limits", **{"working set": "256 MiB"})
        self.assertEqual((r["old median"], r["new median"], r["new / old"]), ("37.0", "38.0", "1.03"))
        # 1 MiB: old 140, 130, 135 -> 135; new 130, 140, 150 -> 140; 1.04.
        r = self.row("The machine's limits", **{"working set": "1 MiB"})
        self.assertEqual(r["new / old"], "1.04")

    def test_summary_ratios_of_each_version(self):
        r = self.row("Ratios within each run", summary="speedup_2t_step", model="corotational")
        self.assertEqual((r["old"], r["new"]), ("1.60 (1.50..1.70)", "1.90 (1.80..2.00)"))

    def test_unmatched_records_are_reported_not_fatal(self):
        self.assertIn("12 records matched; 1 only in the old runs, 1 only in the new.", self.out)
        self.assertIn("- integrate, corotational, float, grid, 1k, 1 thread(s) (kernel)", self.out)
        self.assertIn("- scene/multires_organ/staggered, corotational, float, 1 thread(s) (scene)", self.out)
        self.assertIn("98304 tets in the old runs, 98000 in the new: different meshes", self.out)
        self.assertIn("new-run3.csv:14: a second record for step", self.out)

    def test_bad_input_names_the_file(self):
        p = run("--old", os.path.join(DATA, "no-such.csv"), "--new", os.path.join(DATA, "new-run1.csv"))
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("no-such.csv: No such file or directory", p.stderr)
        with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
            f.write("name,value\nx,1\n")
        try:
            p = run("--old", f.name, "--new", os.path.join(DATA, "new-run1.csv"))
            self.assertNotEqual(p.returncode, 0)
            self.assertIn(f"{f.name}: no column case, kind in the header", p.stderr)
        finally:
            os.unlink(f.name)


if __name__ == "__main__":
    unittest.main(verbosity=2)
