#!/usr/bin/env python3
"""Compares the robustness bench's dumped cases with libigl's exact arrangement.

usage:
  SENC_ROBUSTNESS_DUMP=/tmp/rob cargo bench -p senc-gia --bench robustness
  python3 reports/gia/robustness_oracle.py /tmp/rob

Reads DIR/cases.jsonl (our volume and diagnostics per dumped case) and DIR/case_NNNNNN.obj
(the closed mesh), runs ../shared/tools/penetration_oracle.py's computation on each, and
prints one JSON summary: cases compared, agreeing to 1e-6 relative (1e-12 m^3 absolute), and
the disagreements split by whether our run skipped patches (then our volume is a lower bound
by design) or not.
"""
import json, os, sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '../../../shared/tools'))
from penetration_oracle import read_obj, penetration_volume  # noqa: E402

d = sys.argv[1]
rows = [json.loads(l) for l in open(os.path.join(d, 'cases.jsonl'))]
agree, skipped_dis, clean_dis, failed, details = 0, 0, 0, 0, []
kinds = {}
for r in rows:
    dg = r['diagnostics']
    kind = ('every_500th' if r['case'] % 500 == 0 else
            'negative_sum_dropped' if dg.get('negative_sums', 0) > 0 else
            'perturbed_retries' if dg.get('perturbed_retries', 0) > 0 else
            'probes_disagreed' if dg.get('winding_ray_disagreements', 0) > 0 else
            'flat_tangles' if dg.get('flat_tangles', 0) > 0 else 'negative')
    k = kinds.setdefault(kind, {'n': 0, 'agree': 0, 'disagree_with_skips': 0, 'disagree_without_skips': 0})
    k['n'] += 1
    V, F = read_obj(os.path.join(d, f"case_{r['case']:06d}.obj"))
    try:
        ref, _ = penetration_volume(V, F)
    except BaseException as e:  # the oracle refuses some degenerate meshes
        failed += 1
        continue
    ours = r['volume']
    if abs(ours - ref) <= 1e-6 * abs(ref) + 1e-12:
        agree += 1
        k['agree'] += 1
    elif dg['patches_skipped'] > 0:
        skipped_dis += 1
        k['disagree_with_skips'] += 1
    else:
        clean_dis += 1
        k['disagree_without_skips'] += 1
        details.append({'case': r['case'], 'ours': ours, 'libigl': ref})
print(json.dumps({'compared': len(rows) - failed, 'oracle_failed': failed, 'agree': agree,
                  'disagree_with_skips': skipped_dis, 'disagree_without_skips': clean_dis,
                  'by_kind': kinds, 'without_skips': details[:20]}))
