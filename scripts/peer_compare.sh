#!/usr/bin/env bash
# peer_compare.sh [MESH] [PAIRS]: Mirage's cluster-LOD builder against the peer, meshoptimizer's
# clusterlod.h (../shared/peers/clusterlod, a benchmark harness; nothing of it goes into Mirage).
#   MESH   a PLY under ../shared/data (default stanford-dragon/dragon_vrip.ply)
#   PAIRS  alternated one-thread timing runs of each builder (default 3; the machines are noisy,
#          compare the medians)
# Prints, for both builders: one-thread build seconds, wall and process CPU (Mirage's default build,
# normals included, and its geometric build, positions only as the peer), and the LodQuality measure (symmetric surface
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

echo "== one-thread build, $mesh_rel, $pairs alternated rounds (seconds: wall and process CPU)"
# Each round runs Mirage's default build, the peer, then Mirage's geometric build (--normal-weight 0:
# positions only, as the peer). Wall = the bake span (Mirage) / clodBuild (peer); CPU = the process
# CPU of the same span (MIRAGE_LOD_PROFILE's phases / the driver's clodBuild cpu), which other
# processes on a loaded machine inflate less than the wall time. The peer's driver welds the mesh
# by position before it starts its clock; Mirage's span starts with its own weld + clean (vertices
# deduplicated, degenerate and duplicate triangles removed), so the CPU is also given without that
# phase ("from welded input"): the span the peer's figure covers.
mirage_run() {
  local out
  out=$(MIRAGE_LOD_PROFILE=1 "$root/build/mirage" bench build "$mesh" --threads 1 --json "$@" 2>&1)
  local phases
  phases=$(echo "$out" | grep 'lod wall seconds' | grep -o '([0-9.]*)' | tr -d '()')
  printf '%s %s %s\n' "$(echo "$out" | sed -n 's/^  "seconds": *\([0-9.e+-]*\).*/\1/p' | head -1 | awk '{printf "%.3f", $1}')" \
    "$(echo "$phases" | awk '{s += $1} END {printf "%.3f", s}')" \
    "$(echo "$phases" | awk 'NR > 1 {s += $1} END {printf "%.3f", s}')" # without the first phase, weld+clean
}
peer_run() {
  "$peer_out/clod" "$mesh" | awk '/clodBuild cpu/ {c = $3} / input triangles in / {for (i = 1; i < NF; ++i) if ($i == "in") w = $(i + 1)} END {print w, c}'
}
md_w=() md_c=() md_x=() mg_w=() mg_c=() mg_x=() p_w=() p_c=()
for ((i = 0; i < pairs; ++i)); do
  read -r w c x < <(mirage_run); md_w+=("$w") md_c+=("$c") md_x+=("$x")
  read -r w c < <(peer_run); p_w+=("$w") p_c+=("$c")
  read -r w c x < <(mirage_run --normal-weight 0); mg_w+=("$w") mg_c+=("$c") mg_x+=("$x")
done
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
row() { # name, walls (count n), cpus
  local name=$1 n=$2; shift 2
  local w=("${@:1:n}") c=("${@:n+1}")
  printf '%-28s wall %s  median %s   cpu %s  median %s\n' "$name" "${w[*]}" "$(median "${w[@]}")" "${c[*]}" "$(median "${c[@]}")"
}
row "mirage (default)" "$pairs" "${md_w[@]}" "${md_c[@]}"
row "mirage (--normal-weight 0)" "$pairs" "${mg_w[@]}" "${mg_c[@]}"
row "clusterlod" "$pairs" "${p_w[@]}" "${p_c[@]}"
echo "mirage cpu from welded input (without weld+clean): default ${md_x[*]}  median $(median "${md_x[@]}");" \
  "geometric ${mg_x[*]}  median $(median "${mg_x[@]}")"
for kind in default geometric; do
  if [[ $kind == default ]]; then mw=("${md_w[@]}") mc=("${md_c[@]}") mx=("${md_x[@]}"); else mw=("${mg_w[@]}") mc=("${mg_c[@]}") mx=("${mg_x[@]}"); fi
  awk -v pw="$(median "${p_w[@]}")" -v mw="$(median "${mw[@]}")" -v pc="$(median "${p_c[@]}")" -v mc="$(median "${mc[@]}")" \
    -v mx="$(median "${mx[@]}")" -v k="$kind" \
    'BEGIN { if (mw > 0 && mc > 0 && mx > 0) printf "clusterlod / mirage (%s): wall %.2fx, cpu %.2fx; cpu from welded input as the peer %.2fx (medians)\n", k, pw / mw, pc / mc, pc / mx }'
done

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
