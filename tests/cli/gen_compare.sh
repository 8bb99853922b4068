#!/usr/bin/env bash
# CLI checks for `mirage gen` and `mirage compare`: outputs, error lines, exit codes, nothing written on error.
# Usage: gen_compare.sh <mirage binary> <source dir>
set -u
mirage=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
check() { # check <description> <command...>: the command must succeed
  local what=$1; shift
  if ! "$@"; then echo "FAIL: $what"; failures=$((failures + 1)); fi
}
expect_error() { # expect_error <description> <command...>: exit 2, one "mirage: error:" line
  local what=$1; shift
  local err rc
  err=$("$@" 2>&1 >/dev/null); rc=$?
  if [[ $rc -ne 2 || $(printf '%s\n' "$err" | wc -l) -ne 1 || $err != "mirage: error: "* ]]; then
    echo "FAIL: $what (rc $rc, stderr: $err)"; failures=$((failures + 1))
  fi
}

check "gen blob" "$mirage" gen blob --size 3 -o "$work/blob.glb" --seed 7
check "blob written" test -s "$work/blob.glb"
out=$("$mirage" gen city --size 1 -o "$work/city.glb")
check "gen city reports triangles and instances" grep -q "triangles.*instances.*bytes" <<<"$out"
"$mirage" gen blob --size 3 -o "$work/blob2.glb" --seed 7 >/dev/null
check "gen is deterministic" cmp -s "$work/blob.glb" "$work/blob2.glb"
expect_error "unknown kind" "$mirage" gen castle -o "$work/x.glb"
expect_error "missing output directory" "$mirage" gen blob -o "$work/missing/x.glb"
expect_error "size out of range" "$mirage" gen blob --size 99 -o "$work/x.glb"
check "nothing written on error" test ! -e "$work/x.glb"

# gen grid: copies of a scene as instances (the seed's benchmark scenes), the mesh stored once.
check "gen grid" "$mirage" gen grid --mesh "$work/blob.glb" --instances 7 -o "$work/grid.glb"
info=$("$mirage" info "$work/grid.glb")
check "grid has 7 instances of one mesh" grep -q "meshes 1  instances 7 " <<<"$info"
expect_error "grid without --mesh" "$mirage" gen grid --instances 7 -o "$work/y.glb"
expect_error "grid with a missing mesh" "$mirage" gen grid --mesh "$work/none.glb" --instances 7 -o "$work/y.glb"
expect_error "--instances on another kind" "$mirage" gen blob --instances 7 -o "$work/y.glb"
check "nothing written on grid errors" test ! -e "$work/y.glb"

# Two tiny PNGs made with Python's zlib (no image tools needed).
python3 - "$work" <<'PY'
import struct, sys, zlib
def png(path, w, h, f):
    raw = b"".join(b"\0" + bytes(sum((f(x, y) for x in range(w)), ())) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    with open(path, "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) +
                  chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
png(sys.argv[1] + "/a.png", 32, 24, lambda x, y: (x * 5, y * 7, 100, 255))
png(sys.argv[1] + "/b.png", 32, 24, lambda x, y: (x * 5 + 10, y * 7, 100, 255))
png(sys.argv[1] + "/c.png", 16, 24, lambda x, y: (0, 0, 0, 255))
PY
out=$("$mirage" compare "$work/a.png" "$work/b.png")
check "compare text (+10 on R only: MSE 100/3, psnr 32.90 dB)" grep -q "^psnr 32.90 dB  ssim [0-9.]*  mae 3.333$" <<<"$out"
out=$("$mirage" compare "$work/a.png" "$work/a.png" --json)
check "compare json, identical -> psnr null" grep -q '^{"psnr":null,"ssim":1.000000,"mae":0.0000}$' <<<"$out"
expect_error "size mismatch" "$mirage" compare "$work/a.png" "$work/c.png"
expect_error "missing image" "$mirage" compare "$work/a.png" "$work/none.png"
printf 'garbage' >"$work/bad.png"
expect_error "corrupt image" "$mirage" compare "$work/bad.png" "$work/a.png"

[[ $failures -eq 0 ]] && echo "all gen/compare CLI checks passed"
exit $((failures > 0))
