#!/usr/bin/env bash
# Importer inputs through every command that imports: the fuzzing campaign's reproducers (F3-F6, M1) and paths
# that are not files end in exit 2, one stderr line naming the input, and no output; a strips-only PLY is the
# same mesh to info, build and surfels. Usage: import_inputs.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
mirage_prefix=(timeout 120)
fuzz="$source_dir/../shared/data/fuzz-regressions"

# expect_fail_naming NAME INPUT WANTED_TEXT OUTPUT_FILE -- ARGS...: expect_fail (lib.sh), and the line
# names INPUT (as given) and holds printable ASCII only.
expect_fail_naming() {
  local name=$1 also_fixed="$2: " ascii_only=1
  shift 2
  expect_fail "$name" "$@"
}

# Every importing command on one input: info, render, build.
all_fail() {
  local name=$1 input=$2 wanted=$3
  expect_fail_naming "$name-info" "$input" "$wanted" "" -- info "$input"
  expect_fail_naming "$name-render" "$input" "$wanted" "$tmp/o.png" -- render "$input" -o "$tmp/o.png" --size 32x32
  expect_fail_naming "$name-build" "$input" "$wanted" "$tmp/o.mrg" -- build "$input" -o "$tmp/o.mrg" --quiet
}

if [ -d "$fuzz" ]; then
  all_fail f3 "$fuzz/meshopt_tri_count100.glb" "mode TRIANGLES needs a count divisible by 3"
  all_fail f4 "$fuzz/meshopt_tri_stride12.glb" "mode TRIANGLES needs byteStride 2 or 4"
  all_fail f5 "$fuzz/meshopt_attr_stride3.glb" "mode ATTRIBUTES needs a byteStride divisible by 4"
  all_fail f6 "$fuzz/city_buflen1.glb" "runs past buffer 0 (1 bytes)"
  all_fail m1-mtl "$fuzz/cube_nanmtl.obj" "material 0 'red': a factor is NaN or infinite"
  all_fail m1-matrix "$fuzz/suzanne_hugematrix.gltf" "placed by a NaN or infinite transform"
else
  echo "skip fuzz reproducers: $fuzz absent"
fi

# Paths that are not regular files: one wording whatever the command or the name's extension.
mkdir "$tmp/dir.glb" "$tmp/dir.ply" "$tmp/dir.mrg" "$tmp/scans"
for d in dir.glb dir.ply scans; do all_fail "directory-$d" "$tmp/$d" "is a directory, not a regular file"; done
expect_fail_naming directory-mrg-info "$tmp/dir.mrg" "is a directory, not a regular file" "" -- info "$tmp/dir.mrg"
expect_fail_naming directory-mrg-render "$tmp/dir.mrg" "is a directory, not a regular file" "$tmp/o.png" -- render "$tmp/dir.mrg" -o "$tmp/o.png"
expect_fail_naming directory-surfels "$tmp/dir.ply" "is a directory, not a regular file" "$tmp/s.ply" -- surfels "$tmp/dir.ply" -o "$tmp/s.ply"
mkfifo "$tmp/fifo.ply"
all_fail fifo "$tmp/fifo.ply" "is a FIFO (named pipe), not a regular file"
: >"$tmp/empty.glb"
all_fail empty-glb "$tmp/empty.glb" "empty file (0 bytes)"
printf 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n' >"$tmp/extra.ply"
all_fail ply-counts "$tmp/extra.ply" "element 'face' declares 1 records, the data holds 2"

# A strips-only PLY: triangles for info and build, a mesh (not a point cloud) for surfels.
printf 'ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n1 0 0\n2 0 0\n0 1 0\n1 1 0\n2 1 0\n9 3 0 4 1 -1 4 1 5 2\n' >"$tmp/strips.ply"
if "$mirage" info "$tmp/strips.ply" >"$tmp/stdout" 2>&1 && grep -q "triangles 4" "$tmp/stdout"; then
  pass=$((pass + 1))
else
  echo "FAIL strips-info: $(cat "$tmp/stdout")"; failures=$((failures + 1))
fi
if "$mirage" build "$tmp/strips.ply" -o "$tmp/strips.mrg" --quiet >"$tmp/stdout" 2>&1; then
  pass=$((pass + 1))
else
  echo "FAIL strips-build: $(cat "$tmp/stdout")"; failures=$((failures + 1))
fi
if "$mirage" surfels "$tmp/strips.ply" -o "$tmp/s.ply" --count 50 --resolution 32 --views 2 >"$tmp/stdout" 2>&1 &&
   ! grep -qi "point cloud" "$tmp/stdout"; then
  pass=$((pass + 1))
else
  echo "FAIL strips-surfels: $(cat "$tmp/stdout")"; failures=$((failures + 1))
fi

finish "import inputs"
