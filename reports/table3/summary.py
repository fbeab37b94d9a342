"""Table 3: one line per garment kind and network, over the unseen garments of that kind
and both test motions, from the `table1.json` that `cargo xtask eval` wrote in each
folder beside this script. Medians for the volume (a few tangled rollouts dominate a
mean), means for the rest.

    python3 reports/table3/summary.py > reports/table3/table3.md
"""
import json
import statistics
import sys
from pathlib import Path

KINDS = [("tops", "t-shirts and tops"), ("longsleeves", "long sleeves"), ("dresses", "dresses"),
         ("skirts", "skirts"), ("pants", "trousers and shorts")]


def main():
    here = Path(__file__).parent
    print("| kind | unseen garments | network | median V (cm³) | % frames > 0.01 | body pen. (%) "
          "| from skinned (cm) | rise after 30 frames (cm) | FPS |")
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|")
    for folder, kind in KINDS:
        path = here / folder / "table1.json"
        if not path.exists():
            print(f"missing {path}", file=sys.stderr)
            continue
        rows = json.load(open(path))
        for method in dict.fromkeys(r["method"] for r in rows):
            mine = [r for r in rows if r["method"] == method]
            garments = len({r["garment"] for r in mine})
            mean = lambda k: statistics.mean(r[k] for r in mine if r[k] is not None)
            # A network trained on one garment is named by the method alone.
            name = method if "garments" in method else f"{method}, this kind's garment only"
            print(f"| {kind} | {garments} | {name} | {statistics.median(r['volume_cm3'] for r in mine):.2f} "
                  f"| {mean('pct_above_0_01'):.1f} | {mean('body_penetration_pct'):.2f} "
                  f"| {mean('departure_cm'):.1f} | {mean('rise_30_cm'):.1f} | {mean('fps'):.1f} |")


if __name__ == "__main__":
    main()
