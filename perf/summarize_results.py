#!/usr/bin/env python3
"""Medians over several `pliant bench --csv` runs (docs/performance.md).

    python3 perf/summarize_results.py perf/results/<machine>/run*.csv > summary.md

For every case (case, model, precision, order, size, threads) it prints the median over runs
of ns/tet, the spread (min..max), the median roofline fraction and the working set, and for
the summary records (speed-ups, float/double, orders) the median and range of the ratio. A
shared machine is noisy from minute to minute: medians over runs taken at different times
are steadier than any one run.
"""
import csv
import statistics
import sys
from collections import defaultdict


def num(s):
    try:
        return float(s)
    except (TypeError, ValueError):
        return None


def cell(values, f, form):
    """f(values) formatted, or an empty cell where no run recorded the column (a multiresolution
    scene has no roofline, a skipped one no time)."""
    return format(f(values), form) if values else ""


def main(paths):
    rows = defaultdict(list)
    order = []
    for path in paths:
        with open(path, newline="") as f:
            for r in csv.DictReader(f):
                key = (r["case"], r["kind"], r["model"], r["precision"], r["order"], r["size"], r["threads"])
                if key not in rows:
                    order.append(key)
                rows[key].append(r)
    print(f"Medians over {len(paths)} run(s).\n")
    print("| case | model | precision | order | tets | threads | ns/tet (median) | min..max | B/tet | GB/s | roofline | bound | p99 us |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for key in order:
        case, kind, model, prec, order_, size, threads = key
        if kind not in ("kernel", "step", "scene"):
            continue
        rs = rows[key]
        ns = [num(r["ns_per_tet"]) for r in rs if num(r["ns_per_tet"])]
        if not ns:
            print(f"| {case} | {model} | {prec} | {order_} | | {threads} | {rs[0]['note']} | | | | | | |")
            continue
        fr = [num(r["roofline_fraction"]) for r in rs if num(r["roofline_fraction"])]
        gb = [num(r["gb_per_s"]) for r in rs if num(r["gb_per_s"])]
        p99 = [num(r["step_p99_us"]) for r in rs if num(r["step_p99_us"])]
        bt = [num(rs[0]["bytes_per_tet"])] if num(rs[0]["bytes_per_tet"]) else []
        roof = cell(fr, lambda v: 100 * statistics.median(v), ".0f")
        print(f"| {case} | {model} | {prec} | {order_} | {rs[0]['tets']} | {threads} | {statistics.median(ns):.2f} "
              f"| {min(ns):.2f}..{max(ns):.2f} | {cell(bt, lambda v: v[0], '.0f')} | {cell(gb, statistics.median, '.1f')} "
              f"| {roof + '%' if roof else ''} | {rs[0]['bound']} | {cell(p99, statistics.median, '.0f')} |")
    # floor p99: the p99 of fixed arithmetic as long as the median step, timed right after the case
    # (`floor_p99_us`, absent from bench CSVs before 2026-11-29): the machine's own tail.
    print("\n| scene | precision | tets | threads | steps/s | step p50 us (range) | p99 us | floor p99 us | max us | real-time factor (range) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for key in order:
        case, kind, model, prec, order_, size, threads = key
        if kind != "scene":
            continue
        rs = rows[key]
        col = {c: [num(r.get(c)) for r in rs if num(r.get(c))]
               for c in ("steps_per_s", "step_p50_us", "step_p99_us", "floor_p99_us", "step_max_us", "realtime_factor")}
        if not col["step_p50_us"]:
            continue
        def median_range(v, form):
            return f"{format(statistics.median(v), form)} ({format(min(v), form)}..{format(max(v), form)})" if v else ""
        print(f"| {case[6:]} | {prec} | {rs[0]['tets']} | {threads} | {cell(col['steps_per_s'], statistics.median, '.0f')} "
              f"| {median_range(col['step_p50_us'], '.1f')} | {cell(col['step_p99_us'], statistics.median, '.1f')} "
              f"| {cell(col['floor_p99_us'], statistics.median, '.1f')} | {cell(col['step_max_us'], statistics.median, '.0f')} | {median_range(col['realtime_factor'], '.2f')} |")
    print("\n| summary | precision | size | threads | median | min..max | unit |")
    print("|---|---|---|---|---|---|---|")
    for key in order:
        case, kind, model, prec, order_, size, threads = key
        if kind != "summary":
            continue
        v = [num(r["value"]) for r in rows[key] if num(r["value"])]
        if v:
            print(f"| {case[8:]} | {prec} | {size} | {threads} | {statistics.median(v):.2f} | {min(v):.2f}..{max(v):.2f} "
                  f"| {rows[key][0]['unit']} |")
    print("\n| machine | precision | threads | MiB | median | min..max |")
    print("|---|---|---|---|---|---|")
    for key in order:
        case, kind, model, prec, order_, size, threads = key
        if kind != "machine" or case == "machine/info":
            continue
        by_size = defaultdict(list)
        for r in rows[key]:
            by_size[r["footprint_mib"]].append(num(r["value"]))
        for mib, v in by_size.items():
            v = [x for x in v if x]
            print(f"| {case[8:]} | {prec} | {threads} | {mib} | {statistics.median(v):.1f} | {min(v):.1f}..{max(v):.1f} |")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
