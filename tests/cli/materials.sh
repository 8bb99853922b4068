#!/usr/bin/env bash
# Material files on the CLI (docs/shading.md): `render --materials`, `info --materials` and
# `build --materials` (baked into the .mrg); a bad material file gets one line naming file, line
# and key, exit 2, and no output.
# Usage: materials.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

expect_ok gen-blob gen blob --size 2 -o "$tmp/blob.glb" || { finish materials; exit; }
printf 'P3\n1 1\n255\n0 0 0\n' >"$tmp/not_png.png"
cat >"$tmp/good.toml" <<'TOML'
[[material]]
name = "red"
model = "blinn-phong"
albedo = [0.9, 0.1, 0.1]
glossiness = 0.6
specular = [0.2, 0.2, 0.2]

[[assign]]
mesh = "*"
use = "red"

[[light]]
position = [0, 2, 2]
color = [1, 1, 1]
intensity = 5
radius = 20
TOML
printf '[[material]]\nname = "steel"\nroughnes = 0.5\n' >"$tmp/typo.toml"
printf '[[material]]\nname = "steel"\nroughness = 2\n' >"$tmp/range.toml"
printf '[[material]]\nname = "a"\nalbedo_texture = "not_png.png"\n' >"$tmp/texture.toml"
printf '[[material]]\nname = "a"\n[[assign]]\nmesh = "no such mesh"\nuse = "a"\n' >"$tmp/nomatch.toml"
printf '[[material]\nname = "a"\n' >"$tmp/syntax.toml"

for bad in typo range texture nomatch syntax; do
  expect_fail "render-$bad" "error: $tmp/$bad.toml:[0-9]*: " "$tmp/out.png" -- render "$tmp/blob.glb" -o "$tmp/out.png" \
    --size 32x24 --materials "$tmp/$bad.toml"
  expect_fail "info-$bad" "error: $tmp/$bad.toml:[0-9]*: " "" -- info "$tmp/blob.glb" --materials "$tmp/$bad.toml"
done
also_fixed='unknown key "roughnes"' expect_fail render-typo-line "typo.toml:3: material \"steel\"" "$tmp/out.png" -- \
  render "$tmp/blob.glb" -o "$tmp/out.png" --size 32x24 --materials "$tmp/typo.toml"
expect_fail render-missing-file "missing.toml" "$tmp/out.png" -- render "$tmp/blob.glb" -o "$tmp/out.png" \
  --materials "$tmp/missing.toml"

# The good path: info lists the file's material with its line, render applies it (red dominates).
if expect_ok info-good info "$tmp/blob.glb" --materials "$tmp/good.toml"; then
  grep -q "\"red\": blinn-phong, OPAQUE, [1-9][0-9]* mesh(es), from $tmp/good.toml:1" "$tmp/stdout" ||
    fail "info-good: no origin line for red: $(cat "$tmp/stdout")"
fi
if expect_ok info-good-json info "$tmp/blob.glb" --materials "$tmp/good.toml" --json; then
  grep -q "\"origin\": \"$tmp/good.toml:1\"" "$tmp/stdout" || fail "info-good-json: no origin: $(cat "$tmp/stdout")"
fi
if expect_ok render-good render "$tmp/blob.glb" -o "$tmp/red.png" --size 48x32 --materials "$tmp/good.toml"; then
  expect_ok render-plain render "$tmp/blob.glb" -o "$tmp/plain.png" --size 48x32
  cmp -s "$tmp/red.png" "$tmp/plain.png" && fail "render-good: the material file changed nothing"
fi

# build --materials bakes the file's materials and light into the .mrg (SCEN chunk version 2):
# render shows them without the flag, as render --materials does on a plain build; info says
# where each material came from.
expect_fail build-typo "typo.toml:3: material \"steel\"" "$tmp/typo.mrg" -- build gen:blob:2 -o "$tmp/typo.mrg" \
  --materials "$tmp/typo.toml"
if expect_ok build-baked build gen:blob:2 -o "$tmp/baked.mrg" --materials "$tmp/good.toml" --quiet &&
  expect_ok build-plain build gen:blob:2 -o "$tmp/plain.mrg" --quiet &&
  expect_ok render-baked render "$tmp/baked.mrg" -o "$tmp/baked.png" --size 48x32 &&
  expect_ok render-applied render "$tmp/plain.mrg" -o "$tmp/applied.png" --size 48x32 --materials "$tmp/good.toml" &&
  expect_ok render-plain-mrg render "$tmp/plain.mrg" -o "$tmp/plain_mrg.png" --size 48x32; then
  check baked-equals-applied cmp -s "$tmp/baked.png" "$tmp/applied.png"
  cmp -s "$tmp/baked.png" "$tmp/plain_mrg.png" && fail "render-baked: the baked material file changed nothing"
  if expect_ok info-baked info "$tmp/baked.mrg"; then
    grep -q "\"red\": blinn-phong, OPAQUE, [1-9][0-9]* mesh(es), from $tmp/good.toml:1 (baked)" "$tmp/stdout" &&
      grep -q "point lights 1" "$tmp/stdout" || fail "info-baked: no baked origin or light: $(cat "$tmp/stdout")"
  fi
  # One changed byte in the SCEN payload (the first chunk: its offset at table entry 0, byte 8):
  # the chunk's checksum rejects the file with one line naming it.
  cp "$tmp/baked.mrg" "$tmp/corrupt.mrg"
  at=$(($(od -An -tu8 -j72 -N8 "$tmp/corrupt.mrg") + 20))
  flip_byte "$tmp/corrupt.mrg" "$at"
  expect_fail render-corrupt-scen "corrupt.mrg: chunk 0 .SCEN. checksum mismatch" "$tmp/corrupt.png" -- render "$tmp/corrupt.mrg" -o "$tmp/corrupt.png" \
    --size 48x32
  expect_fail info-corrupt-scen "corrupt.mrg" "" -- info "$tmp/corrupt.mrg"
  if expect_ok info-plain-mrg info "$tmp/plain.mrg"; then
    grep -q "point lights\|(baked)" "$tmp/stdout" && fail "info-plain-mrg: lists baked materials: $(cat "$tmp/stdout")"
  fi
fi

# A glTF's KHR_lights_punctual point lights are baked too, also when build merges several inputs.
printf '\0\0\0\0\0\0\0\0\0\0\0\0\0\0\200\77\0\0\0\0\0\0\0\0\0\0\0\0\0\0\200\77\0\0\0\0' >"$tmp/t.bin"
cat >"$tmp/lights.gltf" <<'JSON'
{"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_lights_punctual"],
 "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 4, "range": 7}]}},
 "nodes": [{"mesh": 0, "children": [1]}, {"translation": [0, 1, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}}],
 "scenes": [{"nodes": [0]}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
 "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
 "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"uri": "t.bin", "byteLength": 36}]}
JSON
for inputs in "$tmp/lights.gltf" "$tmp/lights.gltf gen:blob:1"; do
  # shellcheck disable=SC2086
  if expect_ok "build-gltf-lights $inputs" build $inputs -o "$tmp/lights.mrg" --quiet &&
    expect_ok "info-gltf-lights $inputs" info "$tmp/lights.mrg"; then
    grep -q "point lights 1" "$tmp/stdout" || fail "build $inputs: the glTF's light is not baked: $(cat "$tmp/stdout")"
  fi
done
# info on the scene file counts its lights, and the material file's.
if expect_ok info-gltf-lights info "$tmp/lights.gltf" --materials "$tmp/good.toml"; then
  grep -q "point lights 2" "$tmp/stdout" || fail "info-gltf-lights: $(cat "$tmp/stdout")"
fi
finish materials
