#!/usr/bin/env python3
# The reference-volume oracle: the volume of space that the surface winds around twice or
# more, or negatively, from libigl's exact arrangement (another route than GIA).
# Kept here so that tools/libigl_answers.py and tools/time_libigl.py can import it.
"""Reference penetration volume of a closed (or fan-closed) triangle mesh, by another route than GIA.

usage: python3 penetration_oracle.py MESH.obj [--close-holes] [--json]
needs: pip install numpy libigl   (libigl 2.6 ships CGAL's exact arrangement)

The surface is cut into the cells of space it bounds (libigl's exact remeshing and cell
extraction); winding numbers are propagated from the outside cell; the penetration volume is
the volume of the cells covered twice or more, plus cells of negative winding (parts pushed
through). With --close-holes every boundary loop is first fanned to its centroid, the closure
SENC describes. For offline fixture generation only: the project's tests read the numbers it
prints, never this script.
"""
import json, sys
from collections import defaultdict, deque
import numpy as np
import igl.copyleft.cgal as cg

def read_obj(path):
    V, F = [], []
    for line in open(path):
        t = line.split()
        if not t: continue
        if t[0] == 'v': V.append([float(x) for x in t[1:4]])
        elif t[0] == 'f':
            idx = [int(x.split('/')[0]) - 1 for x in t[1:]]
            F += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return np.array(V), np.array(F, dtype=np.int64)

def close_holes(V, F):
    count, directed = defaultdict(int), set()
    for f in F:
        for k in range(3):
            a, b = int(f[k]), int(f[(k + 1) % 3])
            count[(min(a, b), max(a, b))] += 1; directed.add((a, b))
    nxt = {}
    for (a, b), c in count.items():
        if c == 1:
            if (a, b) in directed: nxt[b] = a
            else: nxt[a] = b
    V, F, seen = list(V), [tuple(f) for f in F], set()
    for start in list(nxt):
        if start in seen: continue
        loop, v = [], start
        while v not in seen:
            seen.add(v); loop.append(v); v = nxt[v]
        c = len(V); V.append(np.mean([V[i] for i in loop], axis=0))
        F += [(loop[i], loop[(i + 1) % len(loop)], c) for i in range(len(loop))]
    return np.array(V), np.array(F, dtype=np.int64)

def penetration_volume(V, F):
    VV, FF, IF, J, IM = cg.remesh_self_intersections(V, F)
    FF = IM[FF]
    ncell, C = cg.extract_cells(VV, FF)
    adj = [[] for _ in range(ncell)]
    for p, n in C:
        adj[p].append((n, 1)); adj[n].append((p, -1))
    w = np.full(ncell, np.nan); w[0] = 0; q = deque([0])
    while q:
        c = q.popleft()
        for d, s in adj[c]:
            if np.isnan(w[d]): w[d] = w[c] + s; q.append(d)
            elif w[d] != w[c] + s: raise SystemExit('inconsistent winding: the surface is not closed or not consistently oriented')
    a, b, c = VV[FF[:, 0]], VV[FF[:, 1]], VV[FF[:, 2]]
    tv = np.einsum('ij,ij->i', a, np.cross(b, c)) / 6.0
    vol = np.zeros(ncell)
    np.add.at(vol, C[:, 1], tv); np.add.at(vol, C[:, 0], -tv)
    pen = np.abs(vol[(w >= 2) | (w < 0)]).sum()
    return float(pen), len(IF)

if __name__ == '__main__':
    args = sys.argv[1:]
    if not args or args[0].startswith('-'): raise SystemExit(__doc__)
    V, F = read_obj(args[0])
    if '--close-holes' in args: V, F = close_holes(V, F)
    vol, pairs = penetration_volume(V, F)
    if '--json' in args: print(json.dumps({'volume_m3': vol, 'intersecting_face_pairs': pairs, 'faces': int(len(F))}))
    else: print(f'penetration volume {vol:.9e} m^3 ({vol * 1e6:.4f} cm^3), {pairs} intersecting face pairs, {len(F)} faces')
