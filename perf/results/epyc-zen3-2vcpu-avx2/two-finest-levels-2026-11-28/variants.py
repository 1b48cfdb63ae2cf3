# Adaptive variants of scenes/adaptive_organ.json or adaptive_bar.json against the uniform finest
# level and a uniform mesh twice as fine, with the error measure of perf/adaptivity_report (RMS over
# the reference's samples, every ms, of the probe's distance to the reference's, over the reference
# probe's largest displacement) and tet updates from summary.json.
#   SCENE=organ|bar LEVELS=2|3 python3 variants.py '{"refine_above": 2, ...}' ...   (from the repo root,
#   after a Release build in ./build; each argument is the body's multiresolution.adapt object)
# Runs go to $TMPDIR/pliant-variants (kept between calls: the references run once).
import json, subprocess, sys, csv, math, os, tempfile, hashlib
WORK = os.path.join(tempfile.gettempdir(), 'pliant-variants')
os.makedirs(WORK, exist_ok=True)
SCENE = os.environ.get('SCENE', 'organ')
base = json.load(open('scenes/adaptive_%s.json' % SCENE))
NEAR, FAR = ('under_tool', 'right_lobe_tip') if SCENE == 'organ' else ('near', 'tip')
def run(name, mutate):
    d = json.loads(json.dumps(base)); d['output'] = {'probe_every': 0.001}; mutate(d)
    p = os.path.join(WORK, f'{SCENE}_{name}.json'); json.dump(d, open(p, 'w'))
    out = os.path.join(WORK, f'{SCENE}_{name}')
    if not os.path.exists(out + '/summary.json') or os.environ.get('RERUN'):
        subprocess.run(['build/apps/pliant', 'run', p, '-q', '-o', out], check=True, stdout=subprocess.DEVNULL)
    s = json.load(open(out + '/summary.json'))
    tr = {}
    for row in csv.DictReader(open(out + '/probes.csv')):
        tr.setdefault(row['probe'], []).append((float(row['time']), float(row['x']), float(row['y']), float(row['z'])))
    return s, tr
def err(run_tr, ref_tr, probe):
    r = ref_tr[probe]; x = run_tr[probe]
    import bisect
    ts = [a[0] for a in x]
    s = 0; amp = 0; b0 = r[0]
    for (t, *b) in r:
        i = bisect.bisect_left(ts, t)
        if i == 0: a = x[0][1:]
        elif i >= len(x): a = x[-1][1:]
        else:
            w = (t - x[i-1][0]) / (x[i][0] - x[i-1][0]); a = [(1-w)*x[i-1][k+1] + w*x[i][k+1] for k in range(3)]
        s += sum((a[k]-b[k])**2 for k in range(3)); amp = max(amp, math.dist(b, b0[1:]))
    return math.sqrt(s/len(r))/amp
LEVELS = int(os.environ.get('LEVELS', '3'))
def mr(active, adapt=None):
    def f(d):
        m = d['bodies'][0]['multiresolution']; m['active'] = active
        if active == 'adaptive': m['levels'] = LEVELS
        if adapt is None: m.pop('adapt', None)
        else: m['adapt'] = adapt
    return f
fine_s, fine = run('fine', mr(2))
def refine(d):
    if SCENE == 'organ': d['bodies'][0]['mesh']['cell_size'] = 0.005
    else: d['bodies'][0]['mesh']['box']['cells'] = [128, 16, 16]
    d['bodies'][0]['multiresolution'] = {'levels': 1}
finer_s, finer = run('finer', refine)
print('fine vs finer %s %.2f%%, band %.2f%%' % (NEAR, 100*err(fine, finer, NEAR), 200*err(fine, finer, NEAR)))
for spec in sys.argv[1:]:
    adapt = json.loads(spec)
    s, tr = run('v%d_' % LEVELS + hashlib.sha1(spec.encode()).hexdigest()[:12], mr('adaptive', adapt))
    ratio = fine_s['tet_updates'] / s['tet_updates']
    print('%s levels %d: %.1fx fewer tet updates than uniform fine, %s vs fine %.2f%%, vs finer %.2f%%, %s vs finer %.2f%%' % (spec, LEVELS, ratio, NEAR, 100*err(tr, fine, NEAR), 100*err(tr, finer, NEAR), FAR, 100*err(tr, finer, FAR)))
