#!/usr/bin/env python3
"""web/test.html in headless Chromium (scripts/browser_client.py), its two frames checked pixel by
pixel against the scene web/test.js draws: atlas orientation (block rows upward), the wide block's
third triangle, colour-only patches, depth between patches, back-to-front blending of two
transparent patches, a JPEG tiles delta and a removed patch, particles (a look's block the right way
up, a colour-only look half transparent, a look held into the next frame). With the path of test_stream_web as its
argument it also has the C++ JpegTileEncoder write a keyframe and a delta (JpegTiles.WritesBrowserFixture),
decodes them in the browser (web/test.html?fixture=1) and requires the browser's atlas to match the
C++ decoder's (>= 40 dB PSNR: JPEG decoders differ in rounding only; a layout slip costs far more).
Exit 77 (ctest: skipped) without chromium.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "scripts"))
import browser_client  # noqa: E402
import mock_server  # noqa: E402

WIDTH, HEIGHT = 640, 480
EYE_Z, FOV_DEGREES = 3.0, 60.0  # web/test.js: eye (0, 0, 3) looking at the origin, y up
TOLERANCE = 14  # JPEG at quality 0.95 on flat colours, bilinear filtering


def pixel_of(x, y, z):
    """Where the world point lands in the 640x480 image (row 0 at the top)."""
    depth = EYE_Z - z
    t = math.tan(math.radians(FOV_DEGREES) / 2)
    ndc_x = x / (depth * t * WIDTH / HEIGHT)
    ndc_y = y / (depth * t)
    return int((ndc_x + 1) / 2 * WIDTH), int((1 - ndc_y) / 2 * HEIGHT)


RED, GREEN, BLUE, YELLOW = (255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0)
CYAN, MAGENTA, WHITE = (0, 255, 255), (255, 0, 255), (255, 255, 255)
# The forward renderer's background (linear 0.02, 0.022, 0.026), as the page clears to it in sRGB.
BACKGROUND = (39, 41, 45)
# Green under red (alpha 0.5, farther) under white (alpha 0.5, nearer), blended on sRGB values.
BLENDED = (191, 191, 128)
ORANGE, PURPLE = (255, 128, 0), (128, 0, 255)
# Particle B: its colour-only look's green at alpha 128/255 over the background, on sRGB values.
HALF_GREEN = (19, 148, 22)

COMMON = [
    ("patch 0 above its block's middle row: green", (-0.6, 0.3, 0.0), GREEN),
    ("patch 3 where patch 0 is not in front: cyan", (-0.25, -0.75, -0.5), CYAN),
    ("patch 0 in front of patch 3", (-0.7, -0.3, 0.0), None),  # colour per frame below
    ("patch 1 triangles 0-1: blue", (0.25, 0.0, 0.0), BLUE),
    ("patch 1 triangle 2 (the wide block's right half): yellow", (0.62, -0.4, 0.0), YELLOW),
    ("blend patches sorted back to front over green", (-1.0, 0.25, 0.5), BLENDED),
    ("background", (0.0, -1.5, 0.0), BACKGROUND),
    ("particle A above its centre: its look's block's upper rows, orange", (1.2, -0.8, 0.5), ORANGE),
    ("particle A below its centre: purple", (1.2, -1.0, 0.5), PURPLE),
    ("beside particle A: background", (1.5, -0.9, 0.5), BACKGROUND),
]
EXPECTED = [
    COMMON + [("colour-only patch 2: magenta", (1.25, 0.7, 0.0), MAGENTA),
              ("patch 0 below its block's middle row: red", (-1.0, -0.3, 0.0), RED),
              ("particle B of a colour-only look, half transparent", (-1.5, 1.0, 0.5), HALF_GREEN)],
    COMMON + [("patch 2 removed by the delta frame", (1.25, 0.7, 0.0), BACKGROUND),
              ("patch 0's tile repainted white by the delta", (-1.0, -0.3, 0.0), WHITE),
              ("particle B gone in the second frame", (-1.5, 1.0, 0.5), BACKGROUND)],
]


def check_cxx_payloads(chromium, test_binary):
    """C++ encoder -> browser decoder: the atlas texture must match the C++ decoder's image."""
    folder = tempfile.mkdtemp(prefix="mirage-web-fixture-")
    site = os.path.join(folder, "site")
    shutil.copytree(os.path.join(SOURCE, "web"), site)
    env = dict(os.environ, MIRAGE_JPEG_TILES_FIXTURE=site)
    result = subprocess.run([test_binary, "--gtest_filter=*.WritesBrowserFixture"], env=env,
                            capture_output=True, text=True)
    if result.returncode != 0 or not os.path.exists(os.path.join(site, "key.mjt")):
        print(f"FAIL: {test_binary} did not write the payloads:\n{result.stdout[-2000:]}")
        return False
    server = browser_client.serve_directory(site)
    try:
        status = browser_client.run(f"http://127.0.0.1:{server.server_address[1]}/test.html?fixture=1",
                                    os.path.join(folder, "out"), chromium, 90, 320, 240, print)
    finally:
        server.shutdown()
    if status != 0:
        return False
    width, height, rows = browser_client.read_png(os.path.join(folder, "out", "frame_0000.png"))
    with open(os.path.join(site, "expected.rgba"), "rb") as f:
        expected = f.read()
    if len(expected) != width * height * 4:
        print(f"FAIL: the browser's atlas is {width}x{height}, the C++ decoder's has {len(expected) // 4} texels")
        return False
    squared = 0
    for y, row in enumerate(rows):
        for x in range(width):
            for c in range(3):
                d = row[4 * x + c] - expected[4 * (y * width + x) + c]
                squared += d * d
    mse = squared / (width * height * 3)
    psnr = float("inf") if mse == 0 else 10 * math.log10(255 * 255 / mse)
    ok = psnr >= 40
    print(f"{'ok  ' if ok else 'FAIL'} C++ JPEG tiles (keyframe + delta) in the browser vs the C++ decoder: "
          f"{psnr:.1f} dB, need >= 40")
    return site if ok else None


def check_h264(chromium, site):
    """libx264 Annex B access units -> WebCodecs -> atlas texture, against the encoded image."""
    if not os.path.exists(os.path.join(site, "atlas0.h264")):
        print("skip H.264: H264Fixture wrote no stream (libavcodec without libx264)")
        return True
    server = browser_client.serve_directory(site)
    out = os.path.join(os.path.dirname(site), "h264")
    try:
        status = browser_client.run(f"http://127.0.0.1:{server.server_address[1]}/test.html?h264=192,128",
                                    out, chromium, 90, 320, 240, print)
    finally:
        server.shutdown()
    if status != 0:
        return False
    width, height, rows = browser_client.read_png(os.path.join(out, "frame_0000.png"))
    with open(os.path.join(site, "h264_source.rgba"), "rb") as f:
        source = f.read()
    if len(source) != width * height * 4:
        print(f"FAIL: the browser's H.264 atlas is {width}x{height}, the source has {len(source) // 4} texels")
        return False
    squared = sum((rows[y][4 * x + c] - source[4 * (y * width + x) + c]) ** 2
                  for y in range(height) for x in range(width) for c in range(3))
    psnr = 10 * math.log10(255 * 255 * width * height * 3 / max(squared, 1))
    ok = psnr >= 35
    print(f"{'ok  ' if ok else 'FAIL'} H.264 atlas (key + P frame) through WebCodecs vs its source: {psnr:.1f} dB, "
          f"need >= 35")
    return ok


def srgb_to_linear(c):
    c /= 255
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def linear_to_srgb(c):
    c = c * 12.92 if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return 255 * c


# web/index.html against mock_server.py: the path's cameras, one as a --camera string, one as an object.
STREAM_CAMERAS = ["eye=0,0,3,target=0,0,0,fov=60", {"eye": [0.3, 0.1, 2.5], "target": [0.3, 0.1, 0], "fov": 60}]
STREAM_EYES = [(0.0, 0.0, 3.0), (0.3, 0.1, 2.5)]
ATLAS_W, ATLAS_H = 200, 136  # JpegTiles.WritesBrowserFixture's image
SCENE_MIN = (-2, -2, -2)
QUAD_BLOCK_X = (0, 32)  # the quad's block per frame: frame 2 moves it by a block-only entry


def check_stream_client(chromium, site):
    """The served page end to end: Hello (token from the URL fragment, JPEG tiles capability, zstd patch
    sections only where the browser decompresses zstd), a Pose per path camera with that camera,
    Frames with patches, a colour and JPEG tiles (key, then delta plus a removed patch and the quad
    moved to another block by a block-only entry) drawn as the shared atlas layout says."""
    with open(os.path.join(site, "cams.json"), "w") as f:
        json.dump({"cameras": STREAM_CAMERAS}, f)
    payloads = [open(os.path.join(site, name), "rb").read() for name in ("key.mjt", "delta.mjt")]
    with open(os.path.join(site, "expected.rgba"), "rb") as f:
        texels = f.read()
    quad = dict(id=0, triangles=2, alpha=0, log2=5, x=0, y=0,
                positions=[(-0.5, -0.5, 0), (0.5, -0.5, 0), (-0.5, 0.5, 0), (0.5, 0.5, 0)])
    triangle = dict(id=1, triangles=1, alpha=0, log2=255, x=0, y=0, positions=[(0.8, 0.2, 0), (1.2, 0.2, 0), (0.8, 0.6, 0)])
    sent = []

    def script(kind, fields, log):
        log.append((kind, fields))
        if kind == mock_server.HELLO:
            return [mock_server.welcome(SCENE_MIN, (2, 2, 2), ATLAS_W, ATLAS_H, 2)]
        sent.append(fields["sequence"])
        atlas = (mock_server.CODEC_JPEG_TILES, ATLAS_W, ATLAS_H, payloads[min(len(sent), 2) - 1])
        if len(sent) == 1:
            return [mock_server.frame(1, fields["sequence"], [], [quad, triangle], [(1, (255, 0, 255, 255))], atlas,
                                      SCENE_MIN)]
        moved = dict(id=0, triangles=2, alpha=0, log2=5, x=QUAD_BLOCK_X[1], y=0, geometry=False)
        return [mock_server.frame(len(sent), fields["sequence"], [1], [moved], [], atlas, SCENE_MIN)]

    server = mock_server.serve(site, script)
    out = os.path.join(os.path.dirname(site), "stream")
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/index.html?path=cams.json&record=1#token=secret"
        status = browser_client.run(url, out, chromium, 90, WIDTH, HEIGHT, print)
    finally:
        server.shutdown()
    checks = [(not server.problems, f"server saw no malformed message {server.problems}")]
    hellos = [f for k, f in server.log if k == mock_server.HELLO]
    poses = [f for k, f in server.log if k == mock_server.POSE]
    checks.append((len(hellos) == 1 and hellos[0]["token"] == "secret" and
                   hellos[0]["capabilities"] & mock_server.CAPABILITY_JPEG_TILES, f"one Hello with the token {hellos}"))
    checks.append((len(poses) == 2, f"one Pose per camera ({len(poses)})"))
    for i, pose in enumerate(poses[:2]):
        eye, target, up, fov = pose["camera"][0:3], pose["camera"][3:6], pose["camera"][6:9], pose["camera"][9]
        target_expected = (STREAM_EYES[i][0], STREAM_EYES[i][1], 0.0)
        good = (all(abs(a - b) < 1e-5 for a, b in zip(eye + target + up, STREAM_EYES[i] + target_expected + (0, 1, 0)))
                and abs(fov - math.radians(60)) < 1e-5 and pose["predicted"] == pose["camera"] and
                (pose["width"], pose["height"]) == (WIDTH, HEIGHT) and pose["sequence"] == i + 1)
        checks.append((good, f"Pose {i} carries camera {i}: {pose}"))
    if status != 0:
        checks.append((False, "the page finished the path"))
    t = math.tan(math.radians(30))
    for i, eye in enumerate(STREAM_EYES if status == 0 else []):
        width, height, rows = browser_client.read_png(os.path.join(out, f"frame_{i:04d}.png"))

        def pixel(x, y):
            px = int(((x - eye[0]) / (eye[2] * t * WIDTH / HEIGHT) + 1) / 2 * WIDTH)
            py = int((1 - (y - eye[1]) / (eye[2] * t)) / 2 * HEIGHT)
            return px, py, tuple(rows[py][4 * px:4 * px + 3])

        px, py, got = pixel(1.0, 0.33)
        colour = (255, 0, 255) if i == 0 else BACKGROUND
        checks.append((all(abs(g - e) <= TOLERANCE for g, e in zip(got, colour)),
                       f"frame {i}: colour-only patch {'drawn' if i == 0 else 'removed'} at ({px}, {py}): {got}"))
        for wx, wy in [(-0.25, -0.25), (0.2, 0.3)]:
            px, py, got = pixel(wx, wy)
            # The pixel centre back on the z = 0 plane, then the block's texel (a at row 0.5, d at 31.5).
            x = eye[0] + ((px + 0.5) / WIDTH * 2 - 1) * eye[2] * t * WIDTH / HEIGHT
            y = eye[1] + (1 - (py + 0.5) / HEIGHT * 2) * eye[2] * t
            tx, ty = 0.5 + (x + 0.5) * 31 - 0.5, 0.5 + (y + 0.5) * 31 - 0.5
            x0, y0 = int(tx), int(ty)
            fx, fy = tx - x0, ty - y0
            expected = []
            for c in range(3):
                def texel(u, v):
                    return srgb_to_linear(texels[4 * (v * ATLAS_W + QUAD_BLOCK_X[i] + u) + c])
                linear = ((texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx) * (1 - fy) +
                          (texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx) * fy)
                expected.append(round(linear_to_srgb(linear)))
            checks.append((all(abs(g - e) <= 10 for g, e in zip(got, expected)),
                           f"frame {i}: block ({QUAD_BLOCK_X[i]}, 0) texel ({tx + 0.5:.2f}, {ty + 0.5:.2f}) at pixel "
                           f"({px}, {py}): "
                           f"{got}, expected {tuple(expected)}"))
    for ok, text in checks:
        print(f"{'ok  ' if ok else 'FAIL'} stream client: {text}")
    return all(ok for ok, _ in checks)


def main():
    chromium = browser_client.find_chromium(os.environ.get("MIRAGE_CHROMIUM"))
    if not chromium:
        print("skipped: chromium is not installed (scripts/setup, 'browser client test')")
        return 77
    out = tempfile.mkdtemp(prefix="mirage-web-test-")
    server = browser_client.serve_directory(os.path.join(SOURCE, "web"))
    url = f"http://127.0.0.1:{server.server_address[1]}/test.html"
    try:
        status = browser_client.run(url, out, chromium, 90, WIDTH, HEIGHT, print)
    finally:
        server.shutdown()
    if status != 0:
        return 1
    failures = 0
    for index, checks in enumerate(EXPECTED):
        path = os.path.join(out, f"frame_{index:04d}.png")
        if not os.path.exists(path):
            print(f"FAIL: {path} was not written")
            return 1
        width, height, rows = browser_client.read_png(path)
        if (width, height) != (WIDTH, HEIGHT):
            print(f"FAIL: {path} is {width}x{height}, expected {WIDTH}x{HEIGHT}")
            return 1
        for name, point, expected in checks:
            if expected is None:
                expected = RED if index == 0 else WHITE
            x, y = pixel_of(*point)
            got = tuple(rows[y][4 * x:4 * x + 3])
            ok = all(abs(g - e) <= TOLERANCE for g, e in zip(got, expected))
            failures += not ok
            print(f"{'ok  ' if ok else 'FAIL'} frame {index} {name}: pixel ({x}, {y}) = {got}, expected {expected}")
    if len(sys.argv) > 1:
        site = check_cxx_payloads(chromium, sys.argv[1])
        if not site or not check_stream_client(chromium, site) or not check_h264(chromium, site):
            failures += 1
        else:
            shutil.rmtree(os.path.dirname(site), ignore_errors=True)
    if failures:
        print(f"frames kept in {out}")
        return 1
    shutil.rmtree(out, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
