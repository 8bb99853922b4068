#!/usr/bin/env bash
# peer_compare.sh [MESH] [PAIRS]: Mirage's cluster-LOD builder against the peer, meshoptimizer's
# clusterlod.h (../shared/peers/clusterlod, a benchmark harness; nothing of it goes into Mirage).
#   MESH   a PLY under ../shared/data (default stanford-dragon/dragon_vrip.ply)
#   PAIRS  alternated one-thread timing runs of each builder (default 3; the machines are noisy,
#          compare the medians)
# Prints, for both builders: one-thread build seconds (Mirage's default build, normals included),
# and the LodQuality measure (symmetric surface
# distance of DAG cuts at 25 / 6.2 / 1.6 % of the input triangles, both with the same code: the
# peer driver ports tests/lod/lod_quality_test.cpp) with the triangle counts of the cuts and the
# DAG's root. Needs build/mirage and build/tests/test_lod (Release); builds the peer into
# $PEER_OUT (default /tmp/clusterlod-peer) when it is missing. Exits 0 with a message when the peer
# sources or the mesh are absent.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
mesh_rel=${1:-stanford-dragon/dragon_vrip.ply}
pairs=${2:-3}
data=$root/../shared/data
peer_src=$root/../shared/peers/clusterlod
peer_out=${PEER_OUT:-/tmp/clusterlod-peer}
mesh=$data/$mesh_rel
if [[ ! -x $peer_src/build ]]; then
  echo "peer_compare: no peer at $peer_src, nothing to compare"
  exit 0
fi
if [[ ! -f $mesh ]]; then
  echo "peer_compare: no mesh $mesh"
  exit 0
fi
for f in "$root/build/mirage" "$root/build/tests/test_lod"; do
  [[ -x $f ]] || { echo "peer_compare: build $f first (cmake --build build)" >&2; exit 2; }
done
[[ -x $peer_out/clod ]] || "$peer_src/build" "$peer_out" >/dev/null

echo "== one-thread build time, $mesh_rel, $pairs alternated pairs (seconds)"
mirage_times=() peer_times=()
for ((i = 0; i < pairs; ++i)); do
  t=$("$root/build/mirage" bench build "$mesh" --threads 1 --json | sed -n 's/^  "seconds": *\([0-9.e+-]*\).*/\1/p' | head -1)
  mirage_times+=("$t")
  t=$("$peer_out/clod" "$mesh" | sed -n 's/.* triangles in \([0-9.]*\) s .*/\1/p' | head -1)
  peer_times+=("$t")
done
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
mm=$(median "${mirage_times[@]}") pm=$(median "${peer_times[@]}")
echo "mirage     ${mirage_times[*]}  median $mm"
echo "clusterlod ${peer_times[*]}  median $pm"
awk -v m="$mm" -v p="$pm" 'BEGIN { if (m > 0) printf "clusterlod / mirage = %.2fx\n", p / m }'

echo "== LodQuality: symmetric surface distance of the DAG cut at 25 / 6.2 / 1.6 % of the triangles"
quality() {
  MIRAGE_LOD_QUALITY_MESH=$mesh_rel "$@" "$root/build/tests/test_lod" --gtest_also_run_disabled_tests \
    --gtest_filter='LodQuality.DISABLED_CutVersusSimplifyChain' | grep -E 'DAG cut' || true
}
# The peer gets positions only, so the like-for-like row is Mirage's geometric error (weight 0);
# the default build (shading-aware error, vertex normals as imported) spends triangles on shading.
echo "-- mirage, geometric error (positions only, as the peer)"
quality env MIRAGE_LOD_NORMAL_WEIGHT=0
echo "-- mirage, default build (shading-aware error)"
quality env
"$root/build/mirage" bench build "$mesh" --threads 1 | grep -iE '^  root' || true
echo "-- clusterlod"
"$peer_out/clod" "$mesh" --quality | grep -E 'quality at|levels [0-9]+;|coarsest'
