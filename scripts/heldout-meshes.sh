#!/usr/bin/env bash
# Held-out real-object meshes for the GQ-CNN experiment (docs/gqcnn.md, Table 4.1): the Dex-Net
# bar clamp from ../shared/data plus scanned and CAD objects from CGAL's data set, which Debian
# ships in libcgal-demo (downloaded from the Debian archive, not installed; the files keep their
# CGAL data licences and are not copied into the repository). OFF files are converted to OBJ.
#
#   bash scripts/heldout-meshes.sh OUT_DIR           # the 22 held-out meshes
#   bash scripts/heldout-meshes.sh OUT_DIR second    # 18 other real meshes of the same data set
#
# Writes OUT_DIR/<name>.obj. Idempotent: an existing OUT_DIR/<name>.obj is kept.
set -euo pipefail
out=${1:?usage: heldout-meshes.sh OUT_DIR [second]}
set_name=${2:-heldout}
root=$(cd "$(dirname "$0")/.." && pwd)

case "$set_name" in
  heldout)
    # Scanned animals and figures, and machine parts, that are closed 2-manifolds with a stable
    # pose (CGAL's dragon, blade, head, mushroom and pig have holes, its cow a non-manifold
    # vertex, and itemb no stable pose above 1 %: left out).
    mkdir -p "$out"
    cp -n "$root/../shared/data/meshes/dexnet_bar_clamp.obj" "$out/dexnet_bar_clamp.obj"
    names="armadillo bunny00 elephant fandisk hand knot1 bear bull camel cactus dino elk femur
      joint couplingdown anchor beam part dragknob helmet cheese"
    ;;
  second)
    # Real objects of the same data set that share nothing with the held-out set (no variant of
    # one either: no bear_bis, knot2, anchor_dense). Seven are open scans (pig, dragon, head,
    # lion's head, mannequin, mushroom, a machine part with holes), closed by the mesh
    # preparation's hole filling (docs/mesh-grasps.md). Used as a second real test set
    # (docs/gqcnn.md, "A second set of real meshes").
    names="eight handle homer man pinion rotor spool triceratops turbine boeing pipe pig
      ChineseDragon-10kv head lion-head mannequin-devil mech-holes-shark mushroom"
    ;;
  *)
    echo "heldout-meshes: unknown set '$set_name' (heldout or second)" >&2
    exit 2
    ;;
esac
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
missing=0
for name in $names; do [ -f "$out/$name.obj" ] || missing=1; done
if [ "$missing" = 1 ]; then
  (cd "$work" && apt-get download -qq libcgal-demo >/dev/null 2>&1) || {
    [ "$(id -u)" = 0 ] && apt-get update -qq >/dev/null && (cd "$work" && apt-get download -qq libcgal-demo)
  }
  dpkg-deb -x "$work"/libcgal-demo_*.deb "$work/pkg"
  tar xzf "$work/pkg/usr/share/doc/libcgal-dev/data.tar.gz" -C "$work" data/meshes
  for name in $names; do
    src="$work/data/meshes/$name.off"
    [ -f "$src" ] || { echo "heldout-meshes: $name.off is not in this libcgal-demo" >&2; continue; }
    [ -f "$out/$name.obj" ] && continue
    # OFF: "OFF" (or "COFF" with colours after the coordinates), then "V F E" (comments and blank lines allowed), V vertex lines, F face lines
    # "n i0 i1 ...": polygons are fanned into triangles; OBJ indices are 1-based.
    awk -v name="$name" '
      /^[[:space:]]*#/ || NF == 0 { next }
      state == 0 { if ($1 ~ /OFF$/) { if (NF >= 4) { nv = $2; nf = $3; state = 2 } else state = 1; next } }
      state == 1 { nv = $1; nf = $2; state = 2; next }
      state == 2 && v < nv { print "v", $1, $2, $3; v++; next }
      state == 2 && f < nf { for (i = 3; i <= $1; i++) print "f", $2 + 1, $(i) + 1, $(i + 1) + 1; f++ }
    ' "$src" > "$out/$name.obj.tmp"
    mv "$out/$name.obj.tmp" "$out/$name.obj"
  done
fi
ls "$out" | wc -l | xargs echo "heldout-meshes: meshes in $out:"
