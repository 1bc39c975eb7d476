#!/usr/bin/env python3
# bench_table3 before and after a change, from bench/pairs.sh's outputs: per scenario the median
# of the seconds of each build and the median (min-max) over the pairs of after / before.
#   bench/table3_ratios.py [OUT=out/bench/pairs]
import re,statistics,glob
def rows(path):
    out={}
    sec=None
    head=None  # the low table's columns, by name (the table gained columns over time)
    for line in open(path):
        if line.startswith('Table 3 on'): sec='t3'
        elif line.startswith('Very low altitude'): sec='low'
        if not line.startswith('| ') or '---' in line: continue
        c=[x.strip() for x in line.strip().strip('|').split('|')]
        if sec=='t3' and len(c)==13 and c[0] not in ('res m',):
            out[('t3',c[0],c[1],'index')]=float(c[4]); out[('t3',c[0],c[1],'load')]=float(c[6]); out[('t3',c[0],c[1],'roadmap')]=float(c[7]); out[('t3',c[0],c[1],'planning')]=float(c[8])
        if sec=='low' and c[0]=='mesh': head={name:i for i,name in enumerate(c)}
        elif sec=='low' and head:
            out[('low',c[0],c[1],c[2],'total')]=float(c[head['total s']]); out[('low',c[0],c[1],c[2],'solved')]=c[head['legs solved']]
    return out
import sys
out=sys.argv[1] if len(sys.argv)>1 else 'out/bench/pairs'
N=len(glob.glob(f'{out}/after_*.txt'))
base=[rows(f'{out}/before_{i}.txt') for i in range(1,N+1)]
new=[rows(f'{out}/after_{i}.txt') for i in range(1,N+1)]
keys=[k for k in base[0] if not k[-1]=='solved']
print('| scenario | baseline s (median) | this change s (median) | ratio new/base, median of pairs (min-max) |')
print('|---|---|---|---|')
for k in keys:
    if k[0]=='t3' and k[1] not in ('1',): continue
    if k[0]=='t3' and k[-1] not in ('load','roadmap','planning'): continue
    b=[r[k] for r in base]; n=[r[k] for r in new]
    ratios=[y/x if x>0 else float('nan') for x,y in zip(b,n)]
    name=' '.join(k[1:])
    extra=''
    if k[0]=='low': extra=f" (solved {base[0][k[:-1]+('solved',)]} / {new[0][k[:-1]+('solved',)]})"
    print(f'| {name}{extra} | {statistics.median(b):.4f} | {statistics.median(n):.4f} | {statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f}) |')
