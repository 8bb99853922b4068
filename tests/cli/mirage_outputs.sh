#!/usr/bin/env bash
# Mirage's own outputs through the CLI: build reports both triangle counts and its wall time, and
# --quiet prints nothing; a build of near-coincident vertices reads back; info describes every kind
# of .mrg (cluster LOD, surfels, PVS), a surfel PLY and a point cloud; render names the flag a
# surfel-only or PVS-only .mrg needs; a CDAG chunk with a bad local index (checksums valid) is one
# line from every command. Usage: mirage_outputs.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

# A 40 x 40 grid of quads over 2.72 units, each vertex with a distinct twin 4.2e-7 away (the
# encoder needs 23 bits or more), plus one duplicate and one degenerate triangle.
awk 'BEGIN {
  n = 40; s = 2.72 / n
  for (t = 0; t < 2; ++t) for (j = 0; j <= n; ++j) for (i = 0; i <= n; ++i)
    printf "v %.9g %.9g %.9g\n", i * s + t * 4.2e-7, 0.05 * sin(i * 0.7) * cos(j * 0.5), j * s + t * 4.2e-7
  for (t = 0; t < 2; ++t) for (j = 0; j < n; ++j) for (i = 0; i < n; ++i) {
    a = t * (n + 1) * (n + 1) + j * (n + 1) + i + 1; b = a + 1; c = a + n + 1; d = c + 1
    printf "f %d %d %d\nf %d %d %d\n", a, c, b, b, c, d
  }
  printf "f 1 %d 2\nf 1 1 2\n", n + 2
}' >"$tmp/twins.obj"

if expect_ok build-twins build "$tmp/twins.obj" -o "$tmp/twins.mrg"; then
  check "build prints both triangle counts" grep -q "6,402 triangles read, 6,400 after removing 2 degenerate/duplicate" "$tmp/stdout"
  check "build prints its wall time next to the bake time" grep -qE "in [0-9.]+ s wall \(import [0-9.]+ s, bake [0-9.]+ s" "$tmp/stdout"
  expect_ok verify-twins verify "$tmp/twins.mrg" --cuts 20
  expect_ok info-twins info "$tmp/twins.mrg"
  check "info prints both triangle counts" grep -q "6,402 triangles read, 6,400 after removing 2 degenerate/duplicate" "$tmp/stdout"
  check "info lists the chunks" grep -q "'CDAG' x1" "$tmp/stdout"
fi
"$mirage" build "$tmp/twins.obj" -o "$tmp/quiet.mrg" --quiet >"$tmp/stdout" 2>"$tmp/stderr"
check "build --quiet exits 0" test $? -eq 0
check "build --quiet prints nothing" test ! -s "$tmp/stdout" -a ! -s "$tmp/stderr"
check "build --quiet writes the asset" test -s "$tmp/quiet.mrg"

# Surfels: a PLY and a surfel-only .mrg are described; render says --surfels is needed.
if expect_ok surfels-ply surfels gen:blob:3 -o "$tmp/s.ply" --count 100 --resolution 16 --views 3; then
  expect_ok info-surfel-ply info "$tmp/s.ply"
  check "info describes a surfel PLY" grep -q "surfel cloud (mirage surfels), 100 surfels" "$tmp/stdout"
fi
if expect_ok surfels-mrg surfels gen:blob:3 -o "$tmp/s.mrg" --count 100 --resolution 16 --views 3; then
  expect_ok info-surfel-mrg info "$tmp/s.mrg"
  check "info describes a surfel-only .mrg" grep -q "surfels: 100 in one whole-scene cloud" "$tmp/stdout"
  check "info describes the SURF blocks" grep -q "surfel blocks: 1 in prefix order" "$tmp/stdout"
  expect_ok info-surfel-mrg-json info "$tmp/s.mrg" --json
  check "info --json counts the surfels" grep -q '"total": 100' "$tmp/stdout"
  expect_fail render-surfel-only "render it with --surfels" "$tmp/s.png" -- render "$tmp/s.mrg" -o "$tmp/s.png" --size 32x32
fi

# A point cloud PLY (no faces): described, not "no triangles".
if expect_ok gen-points gen points --mesh gen:blob:3 --points 500 -o "$tmp/pts.ply"; then
  expect_ok info-points info "$tmp/pts.ply"
  check "info describes a point cloud" grep -q "point cloud, 500 points, no faces" "$tmp/stdout"
fi

# A PVS-only .mrg.
printf '{"cells":[{"type":"box","position":[0,2,0],"size":[4,2,4]}]}' >"$tmp/cells.json"
if expect_ok pvs pvs gen:city:1 --cells "$tmp/cells.json" -o "$tmp/p.mrg" --rays 2000 --budget 20000; then
  expect_ok info-pvs info "$tmp/p.mrg"
  check "info describes a PVS-only .mrg" grep -q "PVS: 1 view cells" "$tmp/stdout"
  expect_fail render-pvs-only "with --pvs" "$tmp/p.png" -- render "$tmp/p.mrg" -o "$tmp/p.png" --size 32x32
fi

# A CDAG chunk with a local index out of range (checksums valid): every command, one line.
bad="$source_dir/../shared/data/fuzz-regressions/cdag_badindex.mrg"
if [ -f "$bad" ]; then
  expect_fail render-bad-index "local index out of range" "$tmp/b.png" -- render "$bad" -o "$tmp/b.png" --size 64x64
  expect_fail render-surfels-bad-index "local index out of range" "$tmp/b.png" -- render "$bad" --surfels -o "$tmp/b.png" --size 64x64
  expect_fail info-bad-index "local index out of range" "" -- info "$bad"
  expect_fail verify-bad-index "local index out of range" "" -- verify "$bad"
else
  echo "skip: $bad not found (shared data absent)"
fi

finish "cli mirage outputs"
