# The bar's adaptive variants of ../two-finest-levels-2026-11-28/variants.py with its coarser
# levels calibrated (multiresolution.calibrate: moduli scaled to the finest level's first mode),
# and the uniform middle level calibrated. Runs go to $TMPDIR/pliant-calibrated/pliant-variants
# (copy bar_fine* and bar_finer* there from a variants.py run to skip the references: the finest
# level is not scaled, so they are the same runs).
#   python3 calibrated.py LEVELS[,LEVELS] '{...adapt...}' ...   (from the repo root, Release build in ./build)
import os, sys, tempfile
tempfile.tempdir = os.path.join(tempfile.gettempdir(), 'pliant-calibrated')
os.makedirs(tempfile.tempdir, exist_ok=True)
here = os.path.dirname(os.path.abspath(__file__))
src = open(os.path.join(here, '..', 'two-finest-levels-2026-11-28', 'variants.py')).read()
src = src.replace("if adapt is None: m.pop('adapt', None)", "m['calibrate'] = True\n        if adapt is None: m.pop('adapt', None)")
src = src.replace("if active == 'adaptive': m['levels'] = LEVELS", "if active != 2: m['levels'] = LEVELS  # the fine reference keeps the scene's 3 levels")
src += """
s, tr = run('cal_uniform1_L%d' % LEVELS, mr(LEVELS - 2))
print('uniform middle level, calibrated, levels %d: %.1fx fewer, %s vs fine %.2f%%, vs finer %.2f%%, %s vs finer %.2f%%' % (LEVELS, fine_s['tet_updates'] / s['tet_updates'], NEAR, 100*err(tr, fine, NEAR), 100*err(tr, finer, NEAR), FAR, 100*err(tr, finer, FAR)))
"""
os.environ['SCENE'] = 'bar'
levels_list, specs = sys.argv[1].split(','), sys.argv[2:]
for levels in levels_list:
    os.environ['LEVELS'] = levels
    sys.argv = ['variants.py'] + specs
    exec(compile(src, 'variants.py', 'exec'), {'__name__': '__main__'})
