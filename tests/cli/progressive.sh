#!/usr/bin/env bash
# Progressive start of a streamed paged .mrg (docs/render.md, "Residency"): `render --gpu-budget
# --progress-json` records every frame until the residency converged. Bytes received never shrink
# and grow past the first frame, the last frame is the converged image (identical), the first is
# complete (the root pages cover what the converged image covers), and `--bandwidth` is applied:
# the average receive rate stays under the limit, for a file and (with nginx) for a URL. Bad rates
# and --progress-json without a budget fail with one line.
# Usage: progressive.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

# progress_ok NAME FILE [LIMIT_BITS]: the progress file's properties (a rate limit when given).
progress_ok() {
  check "$1" python3 - "$2" "${3:-0}" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); limit = int(sys.argv[2])
f = j['frames']
assert j['converged'] and len(f) >= 3, j
received = [x['bytes_received'] for x in f]
assert all(a <= b for a, b in zip(received, received[1:])), received
assert received[-1] > received[0] > 0, received
assert f[-1]['identical'] and 'psnr_db' not in f[-1], f[-1]
assert not f[0]['identical'] and f[0]['psnr_db'] > 10, f[0]
assert f[0]['covered_fraction'] > 0.9, f[0]
assert all(a['seconds'] <= b['seconds'] for a, b in zip(f, f[1:])), f
assert j['bandwidth_bits_per_second'] == limit, j
if limit:
    rate = received[-1] * 8 / f[-1]['seconds']
    assert rate <= 1.1 * limit, (rate, limit)
PY
}

if expect_ok build-paged build gen:blob:5 -o "$tmp/paged.mrg" --quiet --page-size 8KB; then
  args=(--size 96x72 --gpu-budget 2MB --tau 0.5)
  expect_ok progress-file render "$tmp/paged.mrg" -o "$tmp/file.png" "${args[@]}" --progress-json "$tmp/file.json"
  progress_ok progress-file-json "$tmp/file.json"
  expect_ok render-converged render "$tmp/paged.mrg" -o "$tmp/converged.png" "${args[@]}"
  check progress-same-image cmp -s "$tmp/file.png" "$tmp/converged.png"
  # 4 Mbit/s: the file's reads paced like a link of that speed.
  expect_ok progress-file-limited render "$tmp/paged.mrg" -o "$tmp/limited.png" "${args[@]}" --bandwidth 4Mbit \
    --progress-json "$tmp/limited.json"
  progress_ok progress-file-limited-json "$tmp/limited.json" 4000000
  check progress-file-limited-same-image cmp -s "$tmp/limited.png" "$tmp/converged.png"

  expect_fail bandwidth-unit "bandwidth '20MB': expected a rate like" "$tmp/x.png" -- \
    render "$tmp/paged.mrg" -o "$tmp/x.png" --bandwidth 20MB
  expect_fail bandwidth-zero "bandwidth '0Mbit'" "$tmp/x.png" -- render "$tmp/paged.mrg" -o "$tmp/x.png" --bandwidth 0Mbit
  expect_fail progress-no-budget "--progress-json needs --gpu-budget" "$tmp/x.png" -- \
    render "$tmp/paged.mrg" -o "$tmp/x.png" --progress-json "$tmp/x.json"

  www=$tmp/www
  if start_nginx "$www"; then
    cp "$tmp/paged.mrg" "$www/paged.mrg"
    chmod 644 "$www/paged.mrg"
    expect_ok progress-http render "$url/paged.mrg" -o "$tmp/http.png" "${args[@]}" --progress-json "$tmp/http.json"
    progress_ok progress-http-json "$tmp/http.json"
    check progress-http-same-image cmp -s "$tmp/http.png" "$tmp/converged.png"
    expect_ok progress-http-limited render "$url/paged.mrg" -o "$tmp/http-limited.png" "${args[@]}" \
      --bandwidth 4Mbit --progress-json "$tmp/http-limited.json"
    # The limit is checked as a rate (progress_ok): comparing the two runs' wall times failed on a
    # loaded machine (sanitized, 3.50 s unlimited against 3.32 s limited).
    progress_ok progress-http-limited-json "$tmp/http-limited.json" 4000000
  fi
fi

finish progressive
