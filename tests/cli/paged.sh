#!/usr/bin/env bash
# Paged cluster DAGs through the CLI: `build --page-size` writes CPAG chunks only; `info` describes
# them (pages, root pages, table bytes, page sizes); `verify` checks every page and names a damaged
# one (file, chunk, page); `render` of a paged file gives the non-paged file's image.
# Usage: paged.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

if expect_ok build-plain build gen:blob:4 -o "$tmp/plain.mrg" --quiet &&
   expect_ok build-paged build gen:blob:4 -o "$tmp/paged.mrg" --quiet --page-size 16KB; then
  expect_ok info-paged info "$tmp/paged.mrg"
  check info-paged-holds grep -q "paged cluster-LOD asset" "$tmp/stdout"
  check info-paged-chunk grep -q "CPAG" "$tmp/stdout"
  check info-paged-no-cdag bash -c "! grep -q \"'CDAG'\" '$tmp/stdout'"
  check info-paged-pages grep -Eq "pages: [0-9]+ in 1 paged meshes \([0-9]+ root pages" "$tmp/stdout"
  expect_ok info-paged-json info "$tmp/paged.mrg" --json
  check info-paged-json-fields python3 -c "
import json, sys
j = json.load(open('$tmp/stdout'))['pages']
assert j['pages'] > 4 and j['root_pages'] >= 1 and j['table_bytes'] > 0, j
assert 0 < j['page_bytes_min'] <= j['page_bytes_median'] <= j['page_bytes_max'], j"
  expect_ok verify-paged verify "$tmp/paged.mrg" --cuts 10 --json
  check verify-paged-pages python3 -c "
import json
j = json.load(open('$tmp/stdout'))
assert j['ok'] and j['pages_checked'] > 4, j"
  # A byte inside the last page: the CPAG chunk's payload ends with it (docs/asset.md layout).
  python3 - "$tmp/paged.mrg" "$tmp/flipped.mrg" <<'PY'
import struct, sys
data = bytearray(open(sys.argv[1], 'rb').read())
count = struct.unpack_from('<I', data, 16)[0]
table = struct.unpack_from('<Q', data, 24)[0]
for i in range(count):  # 64-byte entries: type, flags, offset, stored, ...
    e = table + 64 * i
    if data[e:e + 4] == b'CPAG':
        offset, stored = struct.unpack_from('<QQ', data, e + 8)
        data[offset + stored - 40] ^= 0x10  # inside the last block
open(sys.argv[2], 'wb').write(data)
PY
  also_fixed="CPAG" expect_fail verify-flipped-page "flipped.mrg.*page [0-9]" "" -- verify "$tmp/flipped.mrg"
  head -c 3000 "$tmp/paged.mrg" >"$tmp/short.mrg"
  expect_fail verify-truncated-paged "short.mrg" "" -- verify "$tmp/short.mrg"
  expect_ok render-plain render "$tmp/plain.mrg" -o "$tmp/plain.png" --size 64x48
  expect_ok render-paged render "$tmp/paged.mrg" -o "$tmp/paged.png" --size 64x48
  check render-same-image cmp -s "$tmp/plain.png" "$tmp/paged.png"
fi
expect_fail build-page-size-small "--page-size" "$tmp/x.mrg" -- build gen:blob:2 -o "$tmp/x.mrg" --page-size 100

finish paged
