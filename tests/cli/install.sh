#!/usr/bin/env bash
# Mirage as an installed library: `cmake --install` into a temporary prefix, examples/embed built out
# of tree against it (find_package(Mirage), Ninja), mirage.pc checked through pkg-config (flags and a
# link), and the example's frame of a small scene made by the installed `mirage` compared with
# `mirage render` of the same view (validation layers on, as in every GPU test).
# Usage: install.sh MIRAGE_BINARY SOURCE_DIR
set -u
mirage=$1
src=$2
build=$(cd "$(dirname "$mirage")" && pwd) # the binary sits at the top of its build tree
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
cache() { sed -n "s/^$1:[A-Z]*=//p" "$build/CMakeCache.txt"; }

prefix=$tmp/prefix
libdir=$(cache CMAKE_INSTALL_LIBDIR)
if ! cmake --install "$build" --prefix "$prefix" >"$tmp/install.log" 2>&1; then
  cat "$tmp/install.log"; fail "cmake --install"; exit 1
fi
for f in bin/mirage include/mirage/render/cluster_renderer.h include/mirage/shaderio/cluster.h \
         include/mirage/runtime/scene.h "$libdir"/libmirage_runtime.a \
         "$libdir"/libmirage_core.a "$libdir"/libmirage_render.a "$libdir"/libmirage_shaders.a \
         "$libdir"/cmake/Mirage/MirageConfig.cmake "$libdir"/cmake/Mirage/MirageConfigVersion.cmake \
         "$libdir"/pkgconfig/mirage.pc; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done

# The example, configured like this build: same compiler and flags, and the -fsanitize options the
# libraries were compiled with however they were set (a sanitized archive needs a sanitized link).
sanitize=$(python3 - "$build/compile_commands.json" "$src/src/" <<'PY'
import json, sys
flags = set()
for entry in json.load(open(sys.argv[1])):
    if entry["file"].startswith(sys.argv[2]):
        flags.update(f for f in entry.get("command", "").split() if f.startswith("-fsanitize="))
print(" ".join(sorted(flags)))
PY
)
cxxflags="$(cache CMAKE_CXX_FLAGS) $sanitize"
ldflags="$(cache CMAKE_EXE_LINKER_FLAGS) $sanitize"
embed=$tmp/embed
if ! cmake -S "$src/examples/embed" -B "$embed" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
     -DCMAKE_BUILD_TYPE="$(cache CMAKE_BUILD_TYPE)" -DCMAKE_CXX_COMPILER="$(cache CMAKE_CXX_COMPILER)" \
     -DCMAKE_C_COMPILER="$(cache CMAKE_C_COMPILER)" -DCMAKE_CXX_FLAGS="$cxxflags" -DCMAKE_EXE_LINKER_FLAGS="$ldflags" \
     -DCMAKE_CXX_COMPILER_LAUNCHER="$(cache CMAKE_CXX_COMPILER_LAUNCHER)" >"$tmp/configure.log" 2>&1 ||
   ! cmake --build "$embed" >"$tmp/build.log" 2>&1; then
  cat "$tmp/configure.log" "$tmp/build.log" 2>/dev/null; fail "examples/embed does not build against the prefix"; exit 1
fi
grep -q -- "-I$src/include\|-isystem $src/include" "$embed/build.ninja" && fail "example compiled against the source tree"

# pkg-config: the headers resolve, and the example's object links from `pkg-config --libs` alone.
export PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
if ! pc=$(pkg-config --cflags --libs mirage); then
  fail "pkg-config --cflags --libs mirage"
else
  cxx=$(cache CMAKE_CXX_COMPILER)
  # shellcheck disable=SC2046,SC2086
  $cxx -std=c++20 $(pkg-config --cflags mirage) -E "$src/examples/embed/main.cpp" -o /dev/null ||
    fail "main.cpp does not preprocess with pkg-config --cflags mirage"
  object=$(find "$embed" -name 'main.cpp.o' | head -1)
  # shellcheck disable=SC2046,SC2086
  $cxx $cxxflags $ldflags "$object" $(pkg-config --libs mirage) -o "$tmp/embed_pc" ||
    fail "the example does not link with pkg-config --libs mirage ($pc)"
fi

# A small scene from the installed CLI (a blob of radius ~1 at the origin); the example's frame
# against `mirage render` of the same camera.
camera=eye=2.2,1.4,2.6,target=0,0,0,fov=45
"$prefix/bin/mirage" build gen:blob:2 -o "$tmp/blob.mrg" --quiet >/dev/null || { fail "mirage build"; exit 1; }
"$embed/mirage_embed" "$tmp/blob.mrg" "$tmp/embed.png" 160x96 "$camera" >"$tmp/stdout" 2>"$tmp/stderr"
rc=$?
[ $rc -eq 0 ] || { cat "$tmp/stderr"; fail "mirage_embed exits $rc"; }
grep -qi validation "$tmp/stderr" && { cat "$tmp/stderr"; fail "validation messages"; }
grep -q "embed.png: 160x96, [1-9][0-9]* triangles in [1-9][0-9]* clusters" "$tmp/stdout" ||
  fail "the example drew nothing: $(cat "$tmp/stdout")"
python3 - "$tmp/embed.png" <<'PY' || fail "embed.png is not a 160x96 PNG"
import struct, sys
head = open(sys.argv[1], "rb").read(24)
sys.exit(0 if head[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", head[16:24]) == (160, 96) else 1)
PY
"$prefix/bin/mirage" render "$tmp/blob.mrg" -o "$tmp/cli.png" --size 160x96 --camera "$camera" >/dev/null || fail "mirage render"
psnr=$("$prefix/bin/mirage" compare "$tmp/embed.png" "$tmp/cli.png" --json | python3 -c \
  'import json, sys; p = json.load(sys.stdin)["psnr"]; print("inf" if p is None else p)')
python3 -c "import sys; sys.exit(0 if float('$psnr') >= 40 else 1)" || fail "example vs mirage render: psnr $psnr dB < 40"
# Not blank: far from a frame of the background alone (the camera looking away from the blob).
"$prefix/bin/mirage" render "$tmp/blob.mrg" -o "$tmp/empty.png" --size 160x96 --camera eye=0,0,100,target=0,0,200 \
  >/dev/null || fail "mirage render (background)"
blank=$("$prefix/bin/mirage" compare "$tmp/embed.png" "$tmp/empty.png" --json | python3 -c \
  'import json, sys; p = json.load(sys.stdin)["psnr"]; print("inf" if p is None else p)')
python3 -c "import sys; sys.exit(0 if float('$blank') < 30 else 1)" || fail "embed.png looks blank: psnr $blank dB to the background"

# Bad input: one error line, exit 2, nothing written.
err=$("$embed/mirage_embed" "$tmp/missing.mrg" "$tmp/x.png" 2>&1 >/dev/null); rc=$?
[[ $rc -eq 2 && $(printf '%s\n' "$err" | wc -l) -eq 1 && $err == *missing.mrg* && ! -e $tmp/x.png ]] ||
  fail "missing scene: rc $rc, stderr: $err"

[[ $failures -eq 0 ]] && echo "install, find_package(Mirage), pkg-config and examples/embed: all checks passed (psnr $psnr dB to mirage render, $blank dB to the background)"
exit $((failures > 0))
