#!/usr/bin/env bash
# The distributed bake (docs/bake.md): `mpirun -np 4 --oversubscribe mirage build` writes the bytes
# one process writes (cmp) and reports ranks and per-rank units (every mesh exactly once); a bake
# killed mid-way (one process alone; a worker rank of four; rank 0 of four) continues with --resume
# to the same bytes; bad input under mpirun prints one error line, every rank exits non-zero, and
# neither an output nor a journal is left. `surfels --per-mesh` on 4 ranks (lavapipe each) and `pvs`
# (8 cells, Embree on each rank) and the streaming `build gen:many` write the bytes one process
# writes. The streaming build with --resume killed the same ways (one process; a worker and rank 0
# of two) resumes to the uninterrupted bytes, baking no resumed mesh again, and refuses another
# bake's journal. Without mpirun (or in a build without MPI) the single-process parts run.
# Usage: mpi_bake.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 # mpirun refuses root without them

# 24 distinct meshes of uneven size (terrains of 64..88 vertices a side): many small units, so a kill
# after the first finished one lands mid-bake.
inputs=()
for i in $(seq 1 24); do inputs+=("gen:terrain:$((64 + (i % 4) * 8)):$i"); done
mpi=(mpirun -np 4 --oversubscribe)

# kill_mid_bake NAME PID_TO_KILL_CMD OUTPUT LAUNCH...: starts LAUNCH in the background, waits for the
# journal's first entry to be written (whole or torn: the kill may cut it), kills the process PID_TO_KILL_CMD prints (given the launcher's pid), and
# checks the job died without an output.
kill_mid_bake() {
  local name=$1 pick=$2 output=$3
  shift 3
  "$@" >"$tmp/killed.out" 2>"$tmp/killed.err" &
  local job=$! victim=""
  for _ in $(seq 1 600); do
    [ "$(stat -c %s "$output.journal" 2>/dev/null || echo 0)" -gt 20 ] && break # past the header
    kill -0 "$job" 2>/dev/null || break
    sleep 0.02
  done
  victim=$($pick "$job")
  if [ -z "$victim" ]; then
    fail "$name: no process to kill (job ended: $(head -c 300 "$tmp/killed.err"))"
    wait "$job"
    return 1
  fi
  kill -9 "$victim" 2>/dev/null
  wait "$job" 2>/dev/null
  local rc=$?
  if [ $rc -eq 0 ] || [ -e "$output" ]; then
    fail "$name: the bake finished before the kill (exit $rc); the resume below bakes nothing"
  fi
  check "$name-journal-kept" test -s "$output.journal"
}

itself() { echo "$1"; }
# rank_matching MPIRUN_PID PATTERN: the first of mpirun's children whose rank (Open MPI names it in
# the process's environment) matches PATTERN.
rank_matching() {
  local pid
  for pid in $(ps -o pid= --ppid "$1"); do
    if tr '\0' '\n' <"/proc/$pid/environ" 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=$2"; then
      echo "$pid"
      return
    fi
  done
}
some_worker() { rank_matching "$1" '[1-9][0-9]*'; } # a rank that bakes what rank 0 hands it
coordinator() { rank_matching "$1" 0; }              # rank 0: the queue and the journal

# resumed_ok NAME OUTPUT [REFERENCE]: the last run resumed at least one mesh, no rank baked a resumed
# mesh again (gen:many resumes meshes 0..K-1) and every other mesh once, and it wrote the
# reference's bytes (reference.mrg by default); neither the journal nor a partial output is left.
resumed_ok() {
  check "$1-resumed" python3 -c "
import json; j = json.load(open('$tmp/stdout'))
assert 1 <= j['resumed_units'] <= j['meshes'], j['resumed_units']
if j.get('streamed'):
    units = sorted(u for r in j['per_rank'] for u in r['units'])
    assert units == list(range(j['resumed_units'], j['meshes'])), units
print('$1: resumed', j['resumed_units'], 'of', j['meshes'], 'meshes')"
  check "$1-same-bytes" cmp "${3:-$tmp/reference.mrg}" "$2"
  check "$1-journal-removed" test ! -e "$2.journal" -a ! -e "$2.partial" -a ! -e "$2.tmap"
}

# One process: the reference, its journal removed after the write, and a killed bake resumed.
if expect_ok reference build "${inputs[@]}" -o "$tmp/reference.mrg" --threads 1 --json; then
  check reference-json python3 -c "
import json; j = json.load(open('$tmp/stdout'))
assert j['meshes'] == 24 and j['ranks'] == 1 and j['resumed_units'] == 0, j
assert sorted(j['per_rank'][0]['units']) == list(range(24)), j['per_rank']"
  check reference-no-journal test ! -e "$tmp/reference.mrg.journal"
  expect_ok again build "${inputs[@]}" -o "$tmp/again.mrg" --quiet
  check same-bytes-any-threads cmp "$tmp/reference.mrg" "$tmp/again.mrg" # no timings in the file

  kill_mid_bake single itself "$tmp/single.mrg" "$mirage" build "${inputs[@]}" -o "$tmp/single.mrg" --threads 1
  expect_ok single-resume build "${inputs[@]}" -o "$tmp/single.mrg" --threads 1 --resume --json &&
    resumed_ok single "$tmp/single.mrg"
  # A journal of another bake is refused, and nothing is written.
  kill_mid_bake other itself "$tmp/other.mrg" "$mirage" build "${inputs[@]}" -o "$tmp/other.mrg" --threads 1
  also_fixed="other.mrg.journal" expect_fail other-journal "journal of another bake" "" -- \
    build "${inputs[@]}" -o "$tmp/other.mrg" --normal-weight 3 --resume
  check other-no-output test ! -e "$tmp/other.mrg"
fi

# The streaming gen:many build with --resume (its partial output and spool kept beside the journal):
# killed mid-bake, resumed to the uninterrupted bytes; another bake's journal refused and left as it is.
stream_args=(build gen:many:16x40000 --paged --threads 1)
if expect_ok stream-reference "${stream_args[@]}" -o "$tmp/stream-reference.mrg" --quiet; then
  kill_mid_bake stream-single itself "$tmp/stream.mrg" "$mirage" "${stream_args[@]}" -o "$tmp/stream.mrg" --resume
  check stream-single-partial-kept test -s "$tmp/stream.mrg.partial" -a -s "$tmp/stream.mrg.tmap"
  expect_ok stream-single-resume "${stream_args[@]}" -o "$tmp/stream.mrg" --resume --json &&
    resumed_ok stream-single "$tmp/stream.mrg" "$tmp/stream-reference.mrg"
  kill_mid_bake stream-other itself "$tmp/stream-other.mrg" "$mirage" "${stream_args[@]}" \
    -o "$tmp/stream-other.mrg" --resume
  also_fixed="stream-other.mrg.journal: journal of another bake" expect_fail stream-other-journal \
    "journal of another bake" "" -- "${stream_args[@]}" -o "$tmp/stream-other.mrg" --normal-weight 3 --resume
  check stream-other-left-as-it-is test -s "$tmp/stream-other.mrg.partial" -a -s "$tmp/stream-other.mrg.journal"
  check stream-other-no-output test ! -e "$tmp/stream-other.mrg"
fi

if ! command -v mpirun >/dev/null; then
  echo "mpirun not found: the distributed parts are skipped"
elif "${mpi[@]}" "$mirage" build gen:blob:2 -o "$tmp/probe.mrg" --quiet 2>&1 | grep -q "built without MPI"; then
  echo "mirage built without MPI: the distributed parts are skipped"
else
  # mpi_matches NAME REFERENCE OUTPUT UNITS ARGS...: `mirage ARGS -o OUTPUT` on the ranks exits 0 and
  # writes REFERENCE's bytes; with UNITS > 0 (ARGS has --json) its JSON names the 4 ranks and every
  # unit 0..UNITS-1 baked exactly once.
  mpi_matches() {
    local name=$1 reference=$2 output=$3 units=$4
    shift 4
    if ! "${mpi[@]}" "$mirage" "$@" -o "$output" >"$tmp/stdout" 2>"$tmp/stderr"; then
      fail "$name: exit non-zero: $(head -c 600 "$tmp/stderr")"
      return 1
    fi
    pass=$((pass + 1))
    check "$name-same-bytes" cmp "$reference" "$output"
    [ "$units" -gt 0 ] || return 0
    check "$name-json" python3 -c "
import json; j = json.load(open('$tmp/stdout'))
assert j['ranks'] == 4 and len(j['per_rank']) == 4, j
units = sorted(u for r in j['per_rank'] for u in r['units'])
assert units == list(range($units)), units"
  }

  mpi_matches mpi-build "$tmp/reference.mrg" "$tmp/mpi.mrg" 24 build "${inputs[@]}" --json

  # A worker killed (mpirun then ends the job), and rank 0 killed (the journal may be cut mid-entry).
  for victim in some_worker coordinator; do
    kill_mid_bake "mpi-kill-$victim" $victim "$tmp/$victim.mrg" "${mpi[@]}" "$mirage" build "${inputs[@]}" \
      -o "$tmp/$victim.mrg" --threads 1
    if "${mpi[@]}" "$mirage" build "${inputs[@]}" -o "$tmp/$victim.mrg" --resume --json >"$tmp/stdout" 2>"$tmp/stderr"; then
      pass=$((pass + 1))
      resumed_ok "mpi-$victim" "$tmp/$victim.mrg"
    else
      fail "mpi-resume-$victim: exit non-zero: $(head -c 600 "$tmp/stderr")"
    fi
  done

  # Surfels per mesh, small clouds: one process, then 4 ranks sampling on their own devices.
  surfel_args=(surfels gen:city:2 --per-mesh --count 300 --resolution 64 --views 4 --quiet)
  if expect_ok surfels-one "${surfel_args[@]}" -o "$tmp/surfels1.mrg"; then
    mpi_matches surfels-mpi "$tmp/surfels1.mrg" "$tmp/surfels4.mrg" 0 "${surfel_args[@]}" &&
      check surfels-no-journal test ! -e "$tmp/surfels4.mrg.journal"
  fi

  # PVS: 8 view cells spread over 4 ranks, each with the scene and its own Embree backend.
  pvs_args=(pvs gen:city:2 --cell-grid 4x1x2 --budget 200000 --rays 50000 --backend embree --json)
  if expect_ok pvs-one "${pvs_args[@]}" -o "$tmp/pvs1.mrg"; then
    mpi_matches pvs-mpi "$tmp/pvs1.mrg" "$tmp/pvs4.mrg" 8 "${pvs_args[@]}"
  fi

  # The streaming gen:many bake: rank 0 writes, every rank generates and bakes the meshes it is
  # handed; the same bytes as one process, every mesh baked exactly once.
  many_args=(build gen:many:10x3000 --paged --meshes-in-flight 1)
  if expect_ok many-one "${many_args[@]}" -o "$tmp/many1.mrg" --quiet; then
    mpi_matches many-mpi "$tmp/many1.mrg" "$tmp/many4.mrg" 10 "${many_args[@]}" --json
  fi

  # The streaming build with --resume on 2 ranks: a worker killed (mpirun ends the job with SIGTERM,
  # which leaves rank 0's partial output), and rank 0 killed mid-write; each resumed on 2 ranks to the
  # one-process bytes, no rank baking a resumed mesh again.
  mpi2=(mpirun -np 2 --oversubscribe)
  for victim in some_worker coordinator; do
    [ -e "$tmp/stream-reference.mrg" ] || break
    out="$tmp/stream-$victim.mrg"
    kill_mid_bake "stream-mpi-kill-$victim" $victim "$out" "${mpi2[@]}" "$mirage" "${stream_args[@]}" -o "$out" --resume
    if "${mpi2[@]}" "$mirage" "${stream_args[@]}" -o "$out" --resume --json >"$tmp/stdout" 2>"$tmp/stderr"; then
      pass=$((pass + 1))
      resumed_ok "stream-mpi-$victim" "$out" "$tmp/stream-reference.mrg"
    else
      fail "stream-mpi-resume-$victim: exit non-zero: $(head -c 600 "$tmp/stderr")"
    fi
  done

  # Bad input: each rank's exit status recorded; one error line in all.
  for bad in "missing-file:$tmp/missing.obj" "bad-option:gen:blob:2 --cluster-triangles 6"; do
    name=${bad%%:*}
    read -r -a args <<<"${bad#*:}"
    rm -f "$tmp/exits"
    "${mpi[@]}" bash -c '"$0" build "$@" -o "'"$tmp"'/bad.mrg"; echo "$OMPI_COMM_WORLD_RANK $?" >>"'"$tmp"'/exits"' \
      "$mirage" "${args[@]}" >"$tmp/stdout" 2>"$tmp/stderr"
    check "mpi-$name-every-rank-fails" python3 -c "
lines = [l.split() for l in open('$tmp/exits')]
assert sorted(int(r) for r, _ in lines) == [0, 1, 2, 3] and all(c == '2' for _, c in lines), lines"
    check "mpi-$name-one-error" test "$(grep -c '^mirage: error: ' "$tmp/stderr")" -eq 1
    check "mpi-$name-nothing-written" bash -c "! ls '$tmp'/bad.mrg* 2>/dev/null"
  done
fi

finish mpi_bake
