#!/usr/bin/env python3
"""Cross-check of penetration_oracle.py by a third route: Monte Carlo over generalized winding
numbers. Samples N uniform points in a box known to contain every point of winding >= 2 (the
intersection of the two components' bounding boxes for two-component meshes, else the whole
bounding box), evaluates libigl's exact generalized winding number of the (fan-closed)
surface there, and reports box volume x fraction of points with rounded winding >= 2 or < 0,
with its binomial standard error.

usage: python3 tools/check_oracle_mc.py MESH.obj [--close-holes] [--points N] [--seed S]
Prints one JSON object: mc_volume_m3, std_error_m3, points, box.
"""
import json
import os
import sys

import numpy as np
import igl

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from penetration_oracle import read_obj, close_holes  # noqa: E402


def components(F, nv):
    parent = list(range(nv))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for f in F:
        for k in (1, 2):
            ra, rb = find(int(f[0])), find(int(f[k]))
            if ra != rb:
                parent[ra] = rb
    return np.array([find(int(f[0])) for f in F])


def main():
    args = sys.argv[1:]
    if not args or args[0].startswith('-'):
        raise SystemExit(__doc__)
    n = int(args[args.index('--points') + 1]) if '--points' in args else 200_000
    seed = int(args[args.index('--seed') + 1]) if '--seed' in args else 1
    V, F = read_obj(args[0])
    if '--close-holes' in args:
        V, F = close_holes(V, F)
    comp = components(F, len(V))
    labels = np.unique(comp)
    if len(labels) == 2:
        boxes = [V[np.unique(F[comp == c])] for c in labels]
        lo = np.maximum(boxes[0].min(0), boxes[1].min(0))
        hi = np.minimum(boxes[0].max(0), boxes[1].max(0))
    else:
        lo, hi = V.min(0), V.max(0)
    rng = np.random.default_rng(seed)
    Q = lo + (hi - lo) * rng.random((n, 3))
    w = np.rint(igl.winding_number(V, F, Q))
    frac = float(np.mean((w >= 2) | (w < 0)))
    box = float(np.prod(hi - lo))
    print(json.dumps({'mc_volume_m3': box * frac, 'std_error_m3': box * np.sqrt(frac * (1 - frac) / n),
                      'points': n, 'box': [lo.tolist(), hi.tolist()]}))


if __name__ == '__main__':
    main()
