#!/usr/bin/env python3
"""Before and after, side by side: two sets of `pliant bench --csv` runs compared record by record.

    python3 perf/compare_bench.py --old old-run1.csv old-run2.csv ... --new new-run1.csv ... \\
        [--old-label c1dbd21] [--new-label HEAD] [--machine TEXT] [--date TEXT] [--set TEXT] \\
        [--runs-log runs.tsv] [--scene-differs NAME ...] [--note TEXT ...] [--target 2.0] > comparison.md

scripts/bench-against.sh runs both versions alternately and calls this. Records are matched on
(case, kind, model, precision, order, size, threads) -- plus the working set for the machine's
triad ladder -- whatever the column order or the extra columns of either version; a record that
only one version has is listed, not an error. For each matched case the table gives the median
over runs of each version, their ranges (min..max), the speed-up = old median time / new median
time (> 1: the new code is faster) and the range of the speed-ups of the runs taken next to each
other (old run i against new run i). Times: ns per tet for passes and whole steps, the median
step time (p50, us) for scenes. Nothing here judges whether the machine was quiet: the table
states the others' load that each run recorded, and the reader decides.
"""
import argparse
import csv
import math
import os
import statistics
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from summarize_results import num  # noqa: E402  (one parser of the CSV's numbers)

KEY = ("case", "kind", "model", "precision", "order", "size", "threads")
STEP_SIZES = ("10k", "100k", "1M")  # the sizes of the issue 15 target
PRECISIONS = ("float", "double")
THREADS = ("1", "2")


class InputError(Exception):
    pass


def cell(r, column):
    v = r.get(column)
    return v.strip() if isinstance(v, str) else ""


def record_key(r):
    key = [cell(r, c) for c in KEY]
    t = num(key[6])
    if t is not None:
        key[6] = str(int(t))
    if key[0] == "machine/triad":  # one record per working set
        mib = num(cell(r, "footprint_mib"))
        key[4] = f"{mib:g} MiB" if mib is not None else ""
    return tuple(key)


def read_run(path, warnings):
    """One CSV: {key: row}. A missing file or column is an error naming the file."""
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            if reader.fieldnames is None:
                raise InputError(f"{path}: empty file, no CSV header")
            missing = [c for c in ("case", "kind") if c not in reader.fieldnames]
            if missing:
                raise InputError(f"{path}: no column {', '.join(missing)} in the header (is it a `pliant bench --csv` file?)")
            rows = {}
            for line, r in enumerate(reader, start=2):
                if not cell(r, "case"):
                    raise InputError(f"{path}:{line}: empty 'case' field")
                k = record_key(r)
                if k in rows:
                    warnings.append(f"{os.path.basename(path)}:{line}: a second record for {label(k)}; the first is kept")
                    continue
                rows[k] = r
            return rows
    except OSError as e:
        raise InputError(f"{path}: {e.strerror}") from None


def label(k):
    case, kind, model, prec, order, size, threads = k
    parts = [case] + [p for p in (model, prec, order, size) if p] + ([f"{threads} thread(s)"] if threads else [])
    return ", ".join(parts)


def loose_pairs(only_old, only_new):
    """(old key, new key) pairs of records that differ only by the fields a skipped case leaves empty."""
    def blank(k):
        return not any(k[2:6])

    def group(k):
        return (k[0], k[1], k[6])

    pairs = []
    for a, b in ((only_old, only_new), (only_new, only_old)):
        for k in a:
            if not blank(k):
                continue
            others = [o for o in b if group(o) == group(k)]
            if len(others) == 1:
                pairs.append((k, others[0]) if a is only_old else (others[0], k))
    return list(dict.fromkeys(pairs))  # both sides blank: found twice


def size_rank(s):
    """'1k' -> 1e3, '1M' -> 1e6; other labels after the numeric ones, in name order."""
    mult = {"k": 1e3, "M": 1e6}.get(s[-1:], 1)
    v = num(s[:-1] if s[-1:] in "kM" else s)
    return (0, v * mult, "") if v is not None else (1, 0, s)


def sort_key(k):
    case, kind, model, prec, order, size, threads = k
    return (case, model, size_rank(size), order, PRECISIONS.index(prec) if prec in PRECISIONS else 2, prec,
            num(threads) or 0)


def fmt(v):
    if v is None or math.isnan(v):
        return ""
    a = abs(v)
    return f"{v:.0f}" if a >= 100 else f"{v:.1f}" if a >= 10 else f"{v:.2f}"


class Matched:
    """One case in both versions: per run, the value (None where a run lacks it)."""

    def __init__(self, key, old_rows, new_rows, column):
        self.key = key
        self.column = column
        self.old_rows = old_rows
        self.new_rows = new_rows
        self.old = [num(cell(r, column)) if r else None for r in old_rows]
        self.new = [num(cell(r, column)) if r else None for r in new_rows]

    @staticmethod
    def present(vs):
        return [v for v in vs if v is not None and not math.isnan(v)]

    def median(self, which):
        v = self.present(getattr(self, which))
        return statistics.median(v) if v else None

    def span(self, which):
        v = self.present(getattr(self, which))
        return f"{fmt(min(v))}..{fmt(max(v))}" if v else ""

    def speedup(self):  # old time / new time
        o, n = self.median("old"), self.median("new")
        return o / n if o and n else None

    def paired(self):
        s = [o / n for o, n in zip(self.old, self.new) if o and n]
        return f"{min(s):.2f}..{max(s):.2f}" if s else ""

    def first(self, which, column):
        for r in getattr(self, which + "_rows"):
            if r and cell(r, column):
                return cell(r, column)
        return ""

    def busy_max(self):
        v = [num(cell(r, "others_busy")) for r in self.old_rows + self.new_rows if r]
        v = [x for x in v if x is not None]
        return f"{max(v):.2f}" if v else ""

    def note(self):
        """Why a version has no value (a skipped or diverged case), else empty."""
        out = []
        for which in ("old", "new"):
            if not self.present(getattr(self, which)):
                out.append(f"{which}: {self.first(which, 'note') or 'no value'}")
        return "; ".join(out)


def scene_note(m, differs):
    t_old, t_new = m.first("old", "tets"), m.first("new", "tets")
    name = (m.key[0].split("/") + [""])[1]  # scene/NAME[/schedule]
    return "; ".join(filter(None, [
        m.note(),
        "another scene file (see the header)" if name in differs else "",
        "different meshes (see the notes)" if t_old and num(t_new) and t_old != t_new else ""]))


def time_column(kind):
    return "step_p50_us" if kind == "scene" else "ns_per_tet"


def x(v):
    return f"{v:.2f}×" if v is not None else ""


def compare(old_paths, new_paths, args, out):
    warnings = []
    old_runs = [read_run(p, warnings) for p in old_paths]
    new_runs = [read_run(p, warnings) for p in new_paths]
    old_keys = set().union(*old_runs)
    new_keys = set().union(*new_runs)
    partner = {k: k for k in old_keys & new_keys}  # old key -> new key
    # A skipped or failed case leaves model, precision, order and size empty (pliant bench writes
    # only its name, threads and note): such a record matches the one record of the same case,
    # kind and threads that the other version has and this one lacks.
    for k_old, k_new in loose_pairs(sorted(old_keys - new_keys, key=sort_key), sorted(new_keys - old_keys, key=sort_key)):
        partner[k_old] = k_new
    both = sorted(partner, key=sort_key)
    only_old = sorted(old_keys - set(partner), key=sort_key)
    only_new = sorted(new_keys - set(partner.values()), key=sort_key)

    def matched(k, column=None):
        return Matched(k, [r.get(k) for r in old_runs], [r.get(partner[k]) for r in new_runs],
                       column or time_column(k[1]))

    w = out.write
    w(f"# Before and after, side by side: {args.old_label} (old) against {args.new_label} (new)\n\n")
    w(f"- **Machine**: {args.machine}\n" if args.machine else "")
    w(f"- **Date**: {args.date}\n" if args.date else "")
    w(f"- **Runs**: {args.set}\n" if args.set else
      f"- **Runs**: {len(old_paths)} of the old, {len(new_paths)} of the new\n")
    for which, runs in (("old", old_runs), ("new", new_runs)):
        info = next((cell(r[k], "note") for r in runs for k in r if k[0] == "machine/info"), "")
        if info:
            w(f"- **{which} build** (its `machine/info` record): {info}\n")
        busy = [num(cell(row, "others_busy")) for r in runs for row in r.values()
                if cell(row, "kind") in ("kernel", "step", "scene")]
        busy = [b for b in busy if b is not None]
        if busy:
            w(f"- **Load, {which}**: other processes used {statistics.median(busy):.2f} core(s) in the median case "
              f"(max {max(busy):.2f}) while its cases ran (`others_busy`)\n")
        # Multi-thread cases: how far apart the host had put the threads (pliant bench's
        # round_trip_ns, absent from bench CSVs before 2026-11-28).
        trips = [num(cell(row, "round_trip_ns")) for r in runs for row in r.values()
                 if cell(row, "kind") in ("step", "scene")]
        trips = [t for t in trips if t is not None]
        if trips:
            w(f"- **Cache-line round trip, {which}**: {min(trips):.0f}..{max(trips):.0f} ns over its cases on 2+ "
              f"threads, median {statistics.median(trips):.0f} (`round_trip_ns`: their figures compare only at like "
              f"round trips)\n")
    for n in args.scene_differs or []:
        w(f"- **Note**: scenes/{n}.json differs between {args.old_label} and {args.new_label}: the scene/{n} records "
          f"compare different scenes (each version runs its own)\n")
    for n in args.note or []:
        w(f"- **Note**: {n}\n")
    w("\nSpeed-up = median old time / median new time (> 1: the new code is faster); *paired* = the range of "
      "old run i / new run i, the runs taken next to each other. Ranges are min..max over runs.\n")

    if args.runs_log:
        w("\n## Runs (in the order they ran)\n\n")
        try:
            with open(args.runs_log, newline="") as f:
                rows = list(csv.reader(f, delimiter="\t"))
        except OSError as e:
            raise InputError(f"{args.runs_log}: {e.strerror}") from None
        if rows:
            w("| " + " | ".join(rows[0]) + " |\n|" + "---|" * len(rows[0]) + "\n")
            for r in rows[1:]:
                w("| " + " | ".join(r) + " |\n")

    # ---- the target: whole corotational step ----
    steps = [k for k in both if k[0] == "step" and k[1] == "step" and k[2] == "corotational" and k[4] == "grid"]
    w(f"\n## Whole corotational step (`World::step`, box, grid order), ns/tet — target: ≥ {args.target:g}× at "
      f"{', '.join(STEP_SIZES)} tets\n\n")
    w("| tets | precision | threads | old median | old range | new median | new range | speed-up | paired | "
      "others busy (max) | target |\n|---|---|---|---|---|---|---|---|---|---|---|\n")
    for k in steps:
        m = matched(k)
        s = m.speedup()
        target = ("" if k[5] not in STEP_SIZES or s is None else "**met**" if s >= args.target else "missed")
        w(f"| {k[5]} ({m.first('new', 'tets') or m.first('old', 'tets')}) | {k[3]} | {k[6]} | {fmt(m.median('old'))} "
          f"| {m.span('old')} | {fmt(m.median('new'))} | {m.span('new')} | {x(s)} | {m.paired()} | {m.busy_max()} "
          f"| {target or m.note()} |\n")
    have = {(k[5], k[3], k[6]) for k in steps}
    absent = [f"{s} {p} {t}T" for s in STEP_SIZES for p in PRECISIONS for t in THREADS if (s, p, t) not in have]
    if absent:
        w(f"\nTarget cases not in both sets of runs: {', '.join(absent)}"
          f"{' (the quick set has no 100k or 1M whole step)' if any('1M' in a for a in absent) else ''}.\n")

    # ---- scenes ----
    scenes = [k for k in both if k[1] == "scene"]
    w("\n## Scenes (`World::step` of the scene), median step time p50 in µs\n\n")
    w("| scene | precision | threads | tets old / new | old median | old range | new median | new range | speed-up "
      "| paired | real-time factor old → new | others busy (max) | note |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    for k in scenes:
        m = matched(k)
        rt = matched(k, "realtime_factor")
        w(f"| {k[0][6:]} | {k[3]} | {k[6]} | {m.first('old', 'tets')} / {m.first('new', 'tets')} "
          f"| {fmt(m.median('old'))} | {m.span('old')} | {fmt(m.median('new'))} | {m.span('new')} | {x(m.speedup())} "
          f"| {m.paired()} | {fmt(rt.median('old'))} → {fmt(rt.median('new'))} | {m.busy_max()} | {scene_note(m, args.scene_differs or [])} |\n")

    # ---- passes ----
    for title, keys in (
            ("Passes (element, gather, integrate, fused gather + integrate), ns/tet",
             [k for k in both if k[1] == "kernel" and not k[0].startswith("order/")]),
            ("Memory orders (float; 100k tets in the quick set, 1M in the full one), ns/tet",
             [k for k in both if k[0].startswith("order/")])):
        w(f"\n## {title}\n\n")
        w("| pass | model | precision | order | size | threads | old median | old range | new median | new range "
          "| speed-up | paired | note |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
        for k in keys:
            m = matched(k)
            w(f"| {k[0]} | {k[2]} | {k[3]} | {k[4]} | {k[5]} | {k[6]} | {fmt(m.median('old'))} | {m.span('old')} "
              f"| {fmt(m.median('new'))} | {m.span('new')} | {x(m.speedup())} | {m.paired()} | {m.note()} |\n")

    # ---- ratios within each version ----
    summaries = [k for k in both if k[1] == "summary"]
    if summaries:
        w("\n## Ratios within each run (summary records): median (range)\n\n")
        w("| summary | model | precision | size | threads | old | new | unit |\n|---|---|---|---|---|---|---|---|\n")
        for k in summaries:
            m = matched(k, "value")
            w(f"| {k[0][8:]} | {k[2]} | {k[3]} | {k[5]} | {k[6]} | {fmt(m.median('old'))} ({m.span('old')}) "
              f"| {fmt(m.median('new'))} ({m.span('new')}) | {m.first('new', 'unit')} |\n")

    # ---- the machine as each version measured it ----
    machine = [k for k in both if k[1] == "machine" and k[0] != "machine/info"]
    if machine:
        w("\n## The machine's limits as each version's runs measured them (same machine: new / old should be "
          "near 1)\n\n| limit | precision | working set | threads | old median | new median | new / old |\n"
          "|---|---|---|---|---|---|---|\n")
        for k in machine:
            m = matched(k, "value")
            o, n = m.median("old"), m.median("new")
            w(f"| {k[0][8:]} | {k[3]} | {k[4]} | {k[6]} | {fmt(o)} | {fmt(n)} | {n / o if o and n else 0:.2f} |\n")

    # ---- what did not match ----
    notes = list(warnings)
    for k in both:
        if k[1] in ("kernel", "step", "scene"):
            m = matched(k)
            t_old, t_new = m.first("old", "tets"), m.first("new", "tets")
            if t_old and t_new and t_old != t_new and num(t_new):
                text = f"{label(k)}: {t_old} tets in the old runs, {t_new} in the new: different meshes"
                if k[1] == "scene":  # the table's step times then compare different work; per tet:
                    per_tet = matched(k, "ns_per_tet")
                    text += (f", so its step times compare different work; per tet, {fmt(per_tet.median('old'))} ns "
                             f"against {fmt(per_tet.median('new'))} ({x(per_tet.speedup())})")
                notes.append(text)
            n_old, n_new = len(m.present(m.old)), len(m.present(m.new))
            if (n_old, n_new) != (len(old_runs), len(new_runs)) and not m.note():
                notes.append(f"{label(k)}: a value in {n_old} of {len(old_runs)} old runs, "
                             f"{n_new} of {len(new_runs)} new runs")
    w(f"\n## Unmatched records\n\n{len(both)} records matched; {len(only_old)} only in the old runs, "
      f"{len(only_new)} only in the new.\n")
    for which, keys in (("old", only_old), ("new", only_new)):
        if keys:
            w(f"\nOnly in the {which} runs:\n\n" + "".join(f"- {label(k)} ({k[1]})\n" for k in keys))
    if notes:
        w("\nNotes:\n\n" + "".join(f"- {n}\n" for n in notes))


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--old", nargs="+", required=True, help="CSV of the old version's runs, in run order")
    p.add_argument("--new", nargs="+", required=True, help="CSV of the new version's runs, in run order")
    p.add_argument("--old-label", default="old")
    p.add_argument("--new-label", default="new")
    p.add_argument("--machine", help="the machine (lscpu model name)")
    p.add_argument("--date")
    p.add_argument("--set", help="which set and how many runs")
    p.add_argument("--runs-log", help="tab-separated log of the runs (scripts/bench-against.sh writes runs.tsv)")
    p.add_argument("--scene-differs", action="append", metavar="NAME",
                   help="scenes/NAME.json differs between the versions: its records are flagged (repeatable)")
    p.add_argument("--note", action="append", help="a line for the table's header (repeatable)")
    p.add_argument("--target", type=float, default=2.0, help="the whole step's speed-up target (default 2)")
    args = p.parse_args(argv)
    try:
        compare(args.old, args.new, args, sys.stdout)
    except InputError as e:
        sys.exit(f"compare_bench: {e}")


if __name__ == "__main__":
    main(sys.argv[1:])
