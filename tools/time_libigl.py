#!/usr/bin/env python3
"""Time libigl's exact self-intersection remeshing on one mesh, to set next to senc's
criterion benchmark of the same mesh in the same run.

usage: python3 tools/time_libigl.py MESH.obj [--close-holes] [--repeat N] [--volume]

Prints one JSON object:
  faces, intersecting_face_pairs (IF of the remesh), libigl_version,
  remesh_ms        median wall time of igl.copyleft.cgal.remesh_self_intersections(V, F)
                   (full remesh, the step SENC runs every training step),
  remesh_ms_all    every repeat,
  detect_only_ms   median time with detect_only=True (face pairs only, no remesh),
  volume_ms, volume_m3   with --volume: one run of tools/penetration_oracle.py's whole
                   computation (remesh + extract_cells + winding numbers).
Single-threaded as libigl runs it; the OBJ is read once, outside the timed region.
Needs: pip install numpy libigl (2.6.x).
"""
import json
import os
import statistics
import sys
import time
from importlib.metadata import version

import igl.copyleft.cgal as cg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from penetration_oracle import read_obj, close_holes, penetration_volume  # noqa: E402


def timed(f, repeat):
    out, times = None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        times.append((time.perf_counter() - t0) * 1e3)
    return out, times


def main():
    args = sys.argv[1:]
    if not args or args[0].startswith('-'):
        raise SystemExit(__doc__)
    repeat = int(args[args.index('--repeat') + 1]) if '--repeat' in args else 5
    V, F = read_obj(args[0])
    if '--close-holes' in args:
        V, F = close_holes(V, F)
    res, t_full = timed(lambda: cg.remesh_self_intersections(V, F), repeat)
    _, t_detect = timed(lambda: cg.remesh_self_intersections(V, F, detect_only=True), repeat)
    out = {
        'mesh': args[0],
        'faces': int(len(F)),
        'close_holes': '--close-holes' in args,
        'intersecting_face_pairs': int(len(res[2])),
        'remesh_ms': statistics.median(t_full),
        'remesh_ms_all': [round(t, 3) for t in t_full],
        'detect_only_ms': statistics.median(t_detect),
        'repeat': repeat,
        'libigl_version': version('libigl'),
    }
    if '--volume' in args:
        (vol, _), t_vol = timed(lambda: penetration_volume(V, F), 1)
        out['volume_m3'] = vol
        out['volume_ms'] = t_vol[0]
    print(json.dumps(out))


if __name__ == '__main__':
    main()
