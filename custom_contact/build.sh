#!/usr/bin/env bash
# Builds libdemorch_bilinear.so against Debian's libliggghts-dev headers into $1 (an empty dir).
# Usage: build.sh OUTPUT_DIR   (called by orchestrator/engines/liggghts/plugin.py, which caches the result)
set -euo pipefail
out="$1"
here="$(cd "$(dirname "$0")" && pwd)"
inc=/usr/include/liggghts
[ -f "$inc/granular_styles.h" ] || { echo "missing LIGGGHTS headers: apt-get install libliggghts-dev" >&2; exit 2; }
mpi_inc="$(mpicxx --showme:compile 2>/dev/null || true)"
[ -n "$mpi_inc" ] || { echo "missing MPI compiler wrapper: apt-get install mpi-default-dev" >&2; exit 2; }
gen="$out/generated"
mkdir -p "$gen"
# The dev package lacks the generated style headers: list every installed model header, plus ours.
for kind in normal tangential cohesion rolling surface; do
  {
    for header in "$inc"/${kind}_model_*.h; do
      name="$(basename "$header")"
      case "$name" in *_base.h) continue ;; esac
      echo "#include \"$name\""
    done
    [ "$kind" = normal ] && echo '#include "normal_model_bilinear.h"'
  } > "$gen/style_${kind}_model.h"
done
# granular_styles.h includes this list; the plugin registers its variants itself (plugin.cpp).
: > "$gen/style_contact_model.h"
# Debian's flags: no SUPERQUADRIC_ACTIVE_FLAG / NONSPHERICAL_ACTIVE_FLAG.
g++ -O2 -fPIC -shared -std=c++11 -w -fvisibility=hidden -fvisibility-inlines-hidden -DOMPI_SKIP_MPICXX -DMPICH_SKIP_MPICXX \
  -I"$gen" -I"$here" -I"$inc" $mpi_inc \
  "$here/plugin.cpp" -o "$out/libdemorch_bilinear.so" -lliggghts
echo "built $out/libdemorch_bilinear.so"
