"""The peers' own automatic orders (benches/results/real-records.md, "The peers' own automatic orders").
Usage, from the repository root (the venv of realdata.sh; REALDATA_DIR as there):
  benches/peers/.venv-real/bin/python benches/peers/realdata_peer_auto.py benches/peers/realdata_records.json [s20_all.json]
One JSON line per record: SIPPY's automatic orders (IC = AIC, orders 1-10, f = p = 20 or
the record's sippy_horizon) with their validation fits, scored as realdata.py scores, and
each tool's best fixed order 1-10 when a realdata.py --all-orders 10 JSON is given. Not part
of the test suite. (Octave's n4sid(dat) without an order stops at SLICOT IB01OY's
interactive order prompt: not run.)"""
import sys, json, os, signal
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import realdata as rd, numpy as np
import warnings; warnings.filterwarnings('ignore')
from sippy_unipi import system_identification
man = sys.argv[1]
allj = json.load(open(sys.argv[2])) if len(sys.argv) > 2 else {'results': []}
data_dir = os.environ.get('REALDATA_DIR', '/work/realdata')
recs = json.load(open(man))['records']
class TO(Exception): pass
def alarm(*a): raise TO()
signal.signal(signal.SIGALRM, alarm)
for rec in recs:
    (ue, ye, uv, yv), N = rd.load_record(rec, data_dir)
    h = rec.get('sippy_horizon', 20)
    out = {'record': rec['name']}
    for meth in ['N4SID', 'MOESP', 'CVA']:
        signal.alarm(120)
        try:
            s = system_identification(ye.T, ue.T, meth, SS_orders=[1, 10], IC='AIC', SS_f=h, SS_p=h)
            signal.alarm(0)
            mats = [np.asarray(s.A), np.asarray(s.B), np.asarray(s.C), np.asarray(s.D)]
            f, _, st, rho = rd.score(mats, uv, yv)
            out[meth] = (mats[0].shape[0], None if f is None else round(f, 1), st)
        except Exception as e:
            signal.alarm(0)
            out[meth] = (None, None, repr(e)[:80])
    # best fixed per tool over orders 1-10 (s20_all)
    best = {}
    for r in allj['results']:
        if r['record'] != rec['name']:
            continue
        cells = {('sippy', k): v for k, v in (r.get('sippy') or {}).items()}
        if r.get('octave'):
            cells[('octave', 'Octave')] = r['octave']
        for k, v in cells.items():
            if v and v.get('fit') is not None:
                if k[1] not in best or v['fit'] > best[k[1]][1]:
                    best[k[1]] = (r['order'], round(v['fit'], 1))
    out['best_fixed'] = best
    print(json.dumps(out), flush=True)
