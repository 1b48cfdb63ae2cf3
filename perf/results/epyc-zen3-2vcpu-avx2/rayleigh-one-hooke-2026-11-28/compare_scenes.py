import csv,statistics as st,sys
A,B=sys.argv[1],sys.argv[2]
def load(f):
    d={}
    for r in csv.DictReader(open(f)):
        if r['kind']=='scene' and r['step_p50_us']:
            d[(r['case'],r['precision'],r['threads'])]=(float(r['step_p50_us']),float(r['step_p99_us']),float(r['realtime_factor'] or 'nan'))
    return d
a=[load(f'scenes-{A}-run{i}.csv') for i in (1,2,3)]
b=[load(f'scenes-{B}-run{i}.csv') for i in (1,2,3)]
print(f"| case | threads | {A} p50 µs | {B} p50 µs | {B}/{A} | {A} p99 | {B} p99 | {A} RT factor | {B} RT factor |")
print("|---|---|---|---|---|---|---|---|---|")
for k in sorted(a[0], key=lambda k:(k[2],k[0],k[1])):
    pa=[x[k][0] for x in a]; pb=[x[k][0] for x in b]
    r=[y/x for x,y in zip(pa,pb)]
    qa=[x[k][1] for x in a]; qb=[x[k][1] for x in b]
    ra=[x[k][2] for x in a]; rb=[x[k][2] for x in b]
    f=lambda v:f"{st.median(v):.1f} ({min(v):.1f}–{max(v):.1f})"
    g=lambda v:f"{st.median(v):.2f}" if v[0]==v[0] else "—"
    print(f"| {k[0]} {k[1]} | {k[2]} | {f(pa)} | {f(pb)} | {st.median(r):.2f} ({min(r):.2f}–{max(r):.2f}) | {st.median(qa):.1f} | {st.median(qb):.1f} | {g(ra)} | {g(rb)} |")
