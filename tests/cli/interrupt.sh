#!/usr/bin/env bash
# An interrupted write leaves nothing beside its output (core/temp_files.h): a streaming
# `mirage build gen:many` stopped by SIGINT (Ctrl-C), SIGTERM (what mpirun sends the other ranks
# when one fails) or SIGHUP while it writes its temp file and spool dies of that signal, and neither
# the output nor the temp file nor the spool is left. A build that is not interrupted still writes.
# With --resume the signals leave the journal, the partial output and the spool instead, and the
# next --resume finishes with the bytes of an uninterrupted build.
# Usage: interrupt.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

# Big enough to be mid-bake for seconds on two cores; the signal goes as soon as the temp file is
# there (created before the first mesh is baked).
scene=gen:many:64x100000
for sig in INT TERM HUP; do
  out="$tmp/$sig/out.mrg"
  mkdir -p "$tmp/$sig"
  # A background job of a script starts with SIGINT ignored (and a process keeps an ignored signal
  # ignored, as mirage does): python puts the default back before it becomes mirage.
  python3 -c 'import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); os.execv(sys.argv[1], sys.argv[1:])' \
    "$mirage" build "$scene" --paged -o "$out" --quiet >"$tmp/$sig.out" 2>"$tmp/$sig.err" &
  job=$!
  for _ in $(seq 1 600); do
    compgen -G "$out.tmp-*" >/dev/null && break
    kill -0 "$job" 2>/dev/null || break
    sleep 0.02
  done
  if ! compgen -G "$out.tmp-*" >/dev/null; then
    fail "$sig: no temp file seen (the build ended first: $(head -c 300 "$tmp/$sig.err"))"
    wait "$job"
    continue
  fi
  kill -s "$sig" "$job"
  wait "$job"
  rc=$?
  check "$sig-died-of-the-signal" test "$rc" -eq $((128 + $(kill -l "$sig")))
  check "$sig-nothing-left" test -z "$(ls -A "$tmp/$sig")"
done

# With --resume (the streaming build keeps a journal): SIGTERM (a batch scheduler's walltime) and
# SIGINT kill the build and leave its journal, partial output and spool; --resume then finishes with
# the bytes of an uninterrupted build and leaves the output alone.
resumable=(build gen:many:16x40000 --paged --threads 1 --quiet)
if expect_ok resume-reference "${resumable[@]}" -o "$tmp/reference.mrg"; then
  for sig in TERM INT; do
    out="$tmp/resume-$sig/out.mrg"
    mkdir -p "$tmp/resume-$sig"
    python3 -c 'import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); os.execv(sys.argv[1], sys.argv[1:])' \
      "$mirage" "${resumable[@]}" -o "$out" --resume >"$tmp/$sig.out" 2>"$tmp/$sig.err" &
    job=$!
    for _ in $(seq 1 600); do
      [ "$(stat -c %s "$out.journal" 2>/dev/null || echo 0)" -gt 20 ] && break # a mesh recorded
      kill -0 "$job" 2>/dev/null || break
      sleep 0.02
    done
    kill -s "$sig" "$job"
    wait "$job"
    rc=$?
    check "resume-$sig-died-of-the-signal" test "$rc" -eq $((128 + $(kill -l "$sig")))
    check "resume-$sig-files-kept" test -s "$out.journal" -a -s "$out.partial" -a -s "$out.tmap" -a ! -e "$out"
  done
  out="$tmp/resume-TERM/out.mrg"
  expect_ok resume-after-TERM "${resumable[@]}" -o "$out" --resume &&
    check resume-same-bytes cmp "$tmp/reference.mrg" "$out" &&
    check resume-only-the-output test "$(ls -A "$tmp/resume-TERM")" = out.mrg
fi

# Not interrupted: the output and nothing else.
mkdir -p "$tmp/whole"
expect_ok whole build gen:many:4x2000 --paged -o "$tmp/whole/out.mrg" --quiet &&
  check whole-only-the-output test "$(ls -A "$tmp/whole")" = out.mrg

finish interrupt
