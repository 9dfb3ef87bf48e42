"""The summary line of a corpus table (bench/urdf-corpus.sh's): how many
files load, run with no failed step with every solver, and stay within
1 mm of penetration and 1e-4 m of joint error with every solver (issue
45's bars). A cell that is not a run (a refusal, or the bench's time cap)
counts against its file. Usage: python3 bench/corpus_summary.py TABLE.md"""
import re, sys
rows = [l for l in open(sys.argv[1]) if l.startswith("| ") and not l.startswith("| robot")]
n = len(rows)
loaded = 0; bars = {0: 0, 1: 0, 2: 0}; allbars = 0; nofail_all = 0
for r in rows:
    cells = [c.strip() for c in r.strip().strip("|").split("|")][1:]
    if all(c.startswith("no:") for c in cells):
        continue
    loaded += 1
    good_all = True; fine_all = True
    for k, c in enumerate(cells):
        m = re.match(r"([\d.]+) s, (\d+) failed, ([\d.e+-]+), ([\d.e+-]+)", c)
        if not m:
            good_all = fine_all = False; continue
        failed = int(m.group(2)); pen = float(m.group(3)); je = float(m.group(4))
        if failed > 0:
            good_all = False
        if failed == 0 and pen < 1e-3 and je < 1e-4: bars[k] += 1
        else: fine_all = False
    nofail_all += good_all; allbars += fine_all
print(f"**Summary**: {n} files, {loaded} load; 0 failed steps with every solver: {nofail_all}; within 1 mm and 1e-4 m with every solver: {allbars} (lemke {bars[0]}, pgs {bars[1]}, auto {bars[2]})")
