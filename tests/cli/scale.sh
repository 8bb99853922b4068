#!/usr/bin/env bash
# Scale (docs/lod.md "Streaming bake"): `build gen:many:COUNTxTRIANGLES --paged` bakes mesh by mesh
# to the same bytes with 1 or 2 threads and any meshes in flight, reports its bounded counters and
# peak RSS in --json; the file renders, and along a fly:N path with a GPU budget each camera's
# converged image is the unbudgeted one (files and, through scripts/serve_ranges.py, a URL);
# `bench render --gpu-budget --path fly:N --json` reports every camera cut and its CPU phases;
# `--resume` with nothing to resume writes the same bytes (cli.mpi_bake and cli.interrupt resume
# killed builds). Bad gen:many sizes fail with one line and write nothing.
# Usage: scale.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

many=gen:many:6x3000
if expect_ok build-1 build "$many" --paged --page-size 16KB -o "$tmp/a.mrg" --threads 1 --json &&
   expect_ok build-2x1 build "$many" --paged --page-size 16KB -o "$tmp/c.mrg" --threads 2 --meshes-in-flight 1 &&
   expect_ok build-2 build "$many" --paged --page-size 16KB -o "$tmp/b.mrg" --threads 2 --meshes-in-flight 3 \
     --reorder-window 3 --json; then
  check same-bytes cmp -s "$tmp/a.mrg" "$tmp/b.mrg"
  check same-bytes-two-threads-per-mesh cmp -s "$tmp/a.mrg" "$tmp/c.mrg"
  check build-json python3 -c "
import json
j = json.load(open('$tmp/stdout'))
assert j['streamed'] and j['meshes'] == 6 and j['input_triangles'] == 6 * 20 * 12 * 12, j
assert j['meshes_in_flight'] == 3 and j['reorder_window'] == 3, j
assert 1 <= j['peak_meshes_in_flight'] <= 3 and j['peak_meshes_waiting'] <= 3, j
assert j['peak_rss_bytes'] > 0 and j['pages'] >= 6 and j['build_seconds'] > 0, j"
  check no-spool bash -c "! ls '$tmp'/*.tmap-* '$tmp'/*.tmp-* 2>/dev/null"
  expect_ok info info "$tmp/a.mrg"
  expect_ok verify verify "$tmp/a.mrg" --cuts 3

  # Along the fly-through, with a budget that holds every view's pages: the unbudgeted images.
  expect_ok render-full render "$tmp/a.mrg" --path fly:3 -o "$tmp/full.png" --size 128x72
  expect_ok render-budget render "$tmp/a.mrg" --path fly:3 -o "$tmp/budget.png" --size 128x72 --gpu-budget 16MB
  for i in 0000 0001 0002; do
    check "fly-$i-same" cmp -s "$tmp/full_$i.png" "$tmp/budget_$i.png"
  done
  expect_ok bench-cuts bench render "$tmp/a.mrg" --gpu-budget 16MB --path fly:3 --size 128x72 --frames 3 \
    --warmup-ms 0 --json
  check bench-cuts-json python3 -c "
import json
j = json.load(open('$tmp/stdout'))
assert j['bench'] == 'render_lod_cuts' and len(j['cameras']) == 3, j
assert j['unconverged_cameras'] == 0 and j['cameras_over_budget'] == 0, j
for c in j['cameras']:
    assert c['converged'] and c['frames_to_full_quality'] >= 1 and c['seconds_to_full_quality'] > 0, c
    assert c['gpu_ms_frame'] > 0 and c['triangles'] > 0 and c['resident_bytes'] <= 16 << 20, c
    t = c['cpu_ms']  # the phases are disjoint intervals of the frames to full quality
    assert t['submit_wait_ms'] > 0 and t['upload_ms'] > 0 and t['decode_threads_ms'] > 0, t
    assert all(v >= 0 for k, v in t.items() if k != 'other_ms') and t['other_ms'] > -1e-3, t
assert j['cameras'][0]['bytes_read'] > 0 and j['worst_gpu_ms_frame'] > 0, j"

  # The same over HTTP: byte ranges from the repository's own server (no nginx needed).
  port=$((20000 + RANDOM % 20000))
  python3 "$source_dir/scripts/serve_ranges.py" "$tmp" --port "$port" >/dev/null 2>&1 &
  server_pids+=("$!")
  for _ in $(seq 1 50); do
    python3 -c "import socket; socket.create_connection(('127.0.0.1', $port), 0.2)" 2>/dev/null && break
    sleep 0.1
  done
  url=http://127.0.0.1:$port/a.mrg
  expect_ok render-http render "$url" --path fly:3 -o "$tmp/http.png" --size 128x72 --gpu-budget 16MB
  for i in 0000 0001 0002; do
    check "http-$i-same" cmp -s "$tmp/full_$i.png" "$tmp/http_$i.png"
  done
  expect_ok bench-cuts-http bench render "$url" --gpu-budget 16MB --path fly:2 --size 128x72 --frames 2 \
    --warmup-ms 0 --json
fi

expect_fail many-count "mesh count out of range" "$tmp/x.mrg" -- build gen:many:0x100 -o "$tmp/x.mrg"
expect_fail many-syntax "COUNTxTRIANGLES" "$tmp/x.mrg" -- build gen:many:4y100 -o "$tmp/x.mrg"
# --resume with no journal: a new resumable bake, the same bytes, nothing left beside the output.
mkdir -p "$tmp/r"
if [ -e "$tmp/a.mrg" ] && expect_ok many-resume-new build "$many" --paged --page-size 16KB -o "$tmp/r/a.mrg" --resume; then
  check many-resume-same-bytes cmp -s "$tmp/a.mrg" "$tmp/r/a.mrg"
  check many-resume-only-the-output test "$(ls -A "$tmp/r")" = a.mrg
fi
expect_fail fly-count "fly:N needs N" "" -- bench render "$tmp/a.mrg" --path fly:0 --gpu-budget 16MB

finish scale
