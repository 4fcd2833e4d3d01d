#!/usr/bin/env bash
# Builds a LIGGGHTS executable with superquadric particles, rounded boxes and the bilinear law compiled in, from
# Debian's own upstream tarball of the installed version (apt-get source; needs a deb-src entry,
# which scripts/setup.sh adds).
# Usage: build_liggghts.sh OUTPUT_DIR DOWNLOAD_DIR
#   (called by orchestrator/engines/liggghts/source_build.py, which caches the result by key)
# Cold build about 6 min on 2 cores (measured 2026-12-02; a rebuild is seconds with ccache installed).
set -euo pipefail
out="$1"
downloads="$2"
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$out" "$downloads"

tarball="$(ls "$downloads"/liggghts_*.orig.tar.* 2>/dev/null | head -1 || true)"
if [ -z "$tarball" ]; then
  (cd "$downloads" && apt-get source --download-only liggghts >"$downloads/apt-source.log" 2>&1) || true
  tarball="$(ls "$downloads"/liggghts_*.orig.tar.* 2>/dev/null | head -1 || true)"
  if [ -z "$tarball" ]; then
    tail -5 "$downloads/apt-source.log" >&2 || true
    echo "could not download LIGGGHTS's source: add a deb-src entry (scripts/setup.sh does) and run apt-get update" >&2
    exit 2
  fi
fi

work="$out/source"
mkdir -p "$work"
tar -xf "$tarball" -C "$work" --strip-components=1
src="$work/src"

# gcc 12: three fixes to the upstream source (no behaviour changes).
sed -i 's|return static_cast< std::ostringstream & >(( std::ostringstream() << std::dec << a ) ).str();|std::ostringstream stream; stream << std::dec << a; return stream.str();|' "$src/utils.h"
sed -i 's|if (neighbor->lists\[m\]->numneigh > 0) {|if (neighbor->lists[m]->numneigh != NULL) {|' "$src/finish.cpp"
rm -f "$src"/dump_mesh_vtk.cpp "$src"/dump_mesh_vtk.h
grep -q "std::ostringstream stream;" "$src/utils.h" || { echo "utils.h fix did not apply" >&2; exit 3; }
grep -q "numneigh != NULL" "$src/finish.cpp" || { echo "finish.cpp fix did not apply" >&2; exit 3; }

# The bilinear law, and only the model combinations this project uses: the generated list would
# stop before the bilinear law, and compiling hundreds of combinations is most of the build time.
cp "$here/normal_model_bilinear.h" "$src/"
# Rounded boxes: pair_style roundedbox, fix wall/roundedbox and their per-atom contact history.
cp "$here"/roundedbox_geometry.h "$here"/roundedbox_candidates.h "$here"/roundedbox_law.h "$here"/pair_roundedbox.* "$here"/fix_wall_roundedbox.* "$here"/fix_roundedbox_history.* "$src/"
{
  for surface in SURFACE_DEFAULT SURFACE_SUPERQUADRIC; do
    for tangential in TANGENTIAL_HISTORY TANGENTIAL_NO_HISTORY; do
      for normal in BILINEAR HOOKE_STIFFNESS; do
        echo "GRAN_MODEL($normal, $tangential, COHESION_OFF, ROLLING_OFF, $surface)"
      done
    done
  done
} > "$src/style_contact_model.whitelist"

launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# ccache: paths relative to the (temporary) build folder, so a rebuild of changed contact code in
# another folder finds the rest of LIGGGHTS in the cache
export CCACHE_BASEDIR="$work" CCACHE_NOHASHDIR=true
flags="-O2 -funroll-loops -fstrict-aliasing -w -std=c++11 -fPIC -DSUPERQUADRIC_ACTIVE_FLAG -DNONSPHERICAL_ACTIVE_FLAG -DHAVE_TR1_CMATH"
mkdir -p "$work/build"
cd "$work/build"
cmake "$src" -DCMAKE_BUILD_TYPE=Release -DCMAKE_DISABLE_FIND_PACKAGE_VTK=ON -DCMAKE_CXX_FLAGS="$flags" "${launcher[@]}" >"$out/cmake.log" 2>&1 \
  || { tail -20 "$out/cmake.log" >&2; exit 4; }
make -j"$(nproc)" liggghts_bin >"$out/make.log" 2>&1 || { grep -m5 -B2 -A5 "error" "$out/make.log" >&2 || tail -30 "$out/make.log" >&2; exit 5; }
cp liggghts "$out/liggghts"
cd "$out"
rm -rf "$work"
styles="$("$out/liggghts" -log none -h 2>/dev/null || true)"
grep -q "nve/superquadric" <<<"$styles" || { echo "the built executable lists no superquadric style" >&2; exit 6; }
grep -q "roundedbox" <<<"$styles" || { echo "the built executable lists no roundedbox style" >&2; exit 6; }
echo "built $out/liggghts"
