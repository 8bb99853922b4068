#!/usr/bin/env bash
# GPU residency through the CLI: `render --gpu-budget` of a paged file renders until the residency
# is stable; with room for the view's pages the image is the unbudgeted one, with a tiny budget the
# image stays complete (coarser) and the resident bytes within the budget; --json reports the
# residency keys; --selection hierarchy and dag give the flat selection's image. Bad budgets, and
# --pvs with a budget, fail with one line and write nothing.
# Usage: residency.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

if expect_ok build-paged build gen:blob:5 -o "$tmp/paged.mrg" --quiet --page-size 8KB &&
   expect_ok build-plain build gen:blob:4 -o "$tmp/plain.mrg" --quiet; then
  expect_ok render-full render "$tmp/paged.mrg" -o "$tmp/full.png" --size 96x72
  expect_ok render-budget render "$tmp/paged.mrg" -o "$tmp/budget.png" --size 96x72 --gpu-budget 2MB --json
  check render-budget-same-image cmp -s "$tmp/full.png" "$tmp/budget.png"
  check render-budget-json python3 -c "
import json
j = json.load(open('$tmp/stdout'))
assert j['gpu_budget'] == 2 * 1024 * 1024, j
assert 0 < j['resident_bytes'] <= j['gpu_budget'] and j['pool_bytes'] <= j['gpu_budget'] + 384, j
assert 0 < j['geometry_bytes'] and 0 < j['record_bytes'] and j['record_bytes'] % 128 == 0, j
assert j['geometry_bytes'] + j['record_bytes'] <= j['resident_bytes'], j
assert 0 < j['cluster_table_bytes'] and 0 < j['tree_node_bytes'], j
assert j['residency_converged'] and j['frames_to_converge'] >= 1, j
frames = j['residency_frames']
assert len(frames) == j['frames_to_converge'] + 2, j
assert all(k in f for f in frames for k in ('requested', 'uploaded', 'evicted', 'resident_bytes')), frames
assert frames[-1]['uploaded'] == 0 and frames[-1]['evicted'] == 0, frames
assert all(f['resident_bytes'] <= j['gpu_budget'] for f in frames), frames"
  expect_ok render-tiny render "$tmp/paged.mrg" -o "$tmp/tiny.png" --size 96x72 --gpu-budget 400KB --json
  check render-tiny-json python3 -c "
import json
j = json.load(open('$tmp/stdout'))
assert j['residency_converged'] and j['resident_pages'] < j['pages'], j
assert all(f['resident_bytes'] <= 400 * 1024 for f in j['residency_frames']), j"
  # Coverage: the coarser image covers the same pixels as the full one, within a silhouette's width.
  check render-tiny-coverage python3 -c "
import zlib, struct
def png(path):
    d = open(path, 'rb').read(); i = 8; idat = b''
    while i < len(d):
        n, t = struct.unpack('>I4s', d[i:i + 8])
        if t == b'IHDR': w, h, depth, ctype = struct.unpack('>IIBB', d[i + 8:i + 18])
        if t == b'IDAT': idat += d[i + 8:i + 8 + n]
        i += 12 + n
    ch = {2: 3, 6: 4}[ctype]; raw = zlib.decompress(idat); rows = []; prev = bytearray(w * ch); k = 0
    for y in range(h):
        f = raw[k]; line = bytearray(raw[k + 1:k + 1 + w * ch]); k += 1 + w * ch
        for x in range(len(line)):
            a = line[x - ch] if x >= ch else 0; b = prev[x]; c = prev[x - ch] if x >= ch else 0
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[x] = (line[x] + [0, a, b, (a + b) // 2, a if pa <= pb and pa <= pc else b if pb <= pc else c][f]) & 255
        rows.append(line); prev = line
    return w, h, ch, rows
w, h, ch, full = png('$tmp/full.png'); _, _, _, tiny = png('$tmp/tiny.png')
bg = full[0][0:3]
cov = lambda rows: {(x, y) for y in range(h) for x in range(w) if rows[y][x * ch:x * ch + 3] != bg}
a, b = cov(full), cov(tiny)
assert len(a) > 500, len(a)
assert len(a ^ b) < 0.1 * len(a), (len(a), len(b), len(a ^ b))"
  expect_fail render-budget-below-roots "below the root pages" "$tmp/x.png" -- render "$tmp/paged.mrg" -o "$tmp/x.png" --gpu-budget 1KB
  expect_fail render-budget-not-paged "paged" "$tmp/x.png" -- render "$tmp/plain.mrg" -o "$tmp/x.png" --gpu-budget 1MB
  # Checked before anything is read: the PVS file need not exist.
  expect_fail render-budget-pvs "--pvs does not apply with --gpu-budget" "$tmp/x.png" -- \
    render "$tmp/paged.mrg" -o "$tmp/x.png" --gpu-budget 2MB --pvs "$tmp/pvs.mrg"
  expect_fail bench-budget-pvs "--pvs does not apply with --gpu-budget" "" -- \
    bench render "$tmp/paged.mrg" --gpu-budget 2MB --pvs "$tmp/pvs.mrg" --frames 2
  # The hierarchical selections draw the flat one's resident cut: the same image.
  for sel in hierarchy dag; do
    expect_ok "render-budget-$sel" render "$tmp/paged.mrg" -o "$tmp/$sel.png" --size 96x72 --gpu-budget 2MB \
      --selection "$sel" --json
    check "render-budget-$sel-json" python3 -c "
import json
j = json.load(open('$tmp/stdout'))
assert j['selection'] == '$sel' and j['residency_converged'], j
assert all(f['resident_bytes'] <= j['gpu_budget'] for f in j['residency_frames']), j"
    check "render-budget-$sel-same-image" cmp -s "$tmp/budget.png" "$tmp/$sel.png"
  done
fi

finish residency
