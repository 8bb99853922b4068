#!/usr/bin/env bash
# `mirage demo` (what `make demo` runs) end to end at a small size: every promised file appears.
set -u
mirage=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if ! "$mirage" demo --out "$tmp/out" --size 160x90 >"$tmp/stdout" 2>"$tmp/stderr"; then
  echo "FAIL: demo exited non-zero"; cat "$tmp/stderr"; echo "demo: 0 passed, 1 failed"; exit 1
fi
failures=0
for f in city.glb terrain.glb blob.glb city-overview.png city-close.png terrain-overview.png blob-close.png city-pvs.mrg \
         blob-lod.mrg blob-lod-tau1.png blob-lod-tau16.png blob-surfels.ply particles_fire.png particles_smoke.png \
         particles_sparks.png particles_rain.png; do
  [ -s "$tmp/out/$f" ] || { echo "FAIL: missing $f"; failures=$((failures + 1)); }
done
grep -q "verified: DAG valid" "$tmp/stdout" || { echo "FAIL: no LOD verification line"; failures=$((failures + 1)); }
"$mirage" verify "$tmp/out/blob-lod.mrg" --cuts 10 >/dev/null || { echo "FAIL: demo asset does not verify"; failures=$((failures + 1)); }
echo "demo: $((14 - failures)) passed, $failures failed"
[ $failures -eq 0 ]
