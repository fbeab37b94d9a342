#!/usr/bin/env python3
"""libigl's answers for the grid-snapped meshes of `tests/fixtures/snapped_cases.json`.

usage:
  cargo run --release -p senc-gia --example export_snapped_cases -- DIR 12 > DIR/cases.jsonl
  python3 tools/snapped_answers.py DIR > tests/fixtures/snapped_cases.json

Reads DIR/cases.jsonl (one line per mesh: seed, senc's volume and diagnostics) and
DIR/snapped_SEED.obj (the closed mesh), computes the penetration volume of libigl's exact
arrangement (../shared/tools/penetration_oracle.py) and prints the answer file.
"""
import json, os, sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '../../shared/tools'))
from penetration_oracle import read_obj, penetration_volume  # noqa: E402
from importlib.metadata import version  # noqa: E402

d = sys.argv[1]
cases = []
for line in open(os.path.join(d, 'cases.jsonl')):
    r = json.loads(line)
    V, F = read_obj(os.path.join(d, f"snapped_{r['seed']}.obj"))
    ref, _ = penetration_volume(V, F)
    cases.append({'seed': r['seed'], 'n_faces': len(F), 'penetration_volume_m3': float(ref)})
print(json.dumps({
    'generator': 'senc_testmesh::crumple_snapped(icosphere((0,0,0), 1, 1) for even seeds, '
                 'tube(0.5, 1.5, 8, 4, Caps::Fan) for odd seeds, amp 0.6, grid 0.25, seed), '
                 'closed by close_holes(All); the seeds from 0 on whose unperturbed winding run skips patches',
    'oracle': 'tools/snapped_answers.py: penetration_oracle.penetration_volume (libigl %s exact arrangement)'
              % version('libigl'),
    'cases': cases,
}, indent=1))
