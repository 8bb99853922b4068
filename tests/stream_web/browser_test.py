#!/usr/bin/env python3
"""web/test.html in headless Chromium (scripts/browser_client.py), its two frames checked pixel by
pixel against the scene web/test.js draws: atlas orientation (block rows upward), the wide block's
third triangle, colour-only patches, depth between patches, back-to-front blending of two
transparent patches, a JPEG tiles delta and a removed patch. With the path of test_stream_web as its
argument it also has the C++ JpegTileEncoder write a keyframe and a delta (JpegTiles.WritesBrowserFixture),
decodes them in the browser (web/test.html?fixture=1) and requires the browser's atlas to match the
C++ decoder's (>= 40 dB PSNR: JPEG decoders differ in rounding only; a layout slip costs far more).
Exit 77 (ctest: skipped) without chromium.
"""
import math
import os
import shutil
import subprocess
import sys
import tempfile

SOURCE = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(SOURCE, "scripts"))
import browser_client  # noqa: E402

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
CYAN, MAGENTA, WHITE, BLACK = (0, 255, 255), (255, 0, 255), (255, 255, 255), (0, 0, 0)
# Green under red (alpha 0.5, farther) under white (alpha 0.5, nearer), blended on sRGB values.
BLENDED = (191, 191, 128)

COMMON = [
    ("patch 0 above its block's middle row: green", (-0.6, 0.3, 0.0), GREEN),
    ("patch 3 where patch 0 is not in front: cyan", (-0.25, -0.75, -0.5), CYAN),
    ("patch 0 in front of patch 3", (-0.7, -0.3, 0.0), None),  # colour per frame below
    ("patch 1 triangles 0-1: blue", (0.25, 0.0, 0.0), BLUE),
    ("patch 1 triangle 2 (the wide block's right half): yellow", (0.62, -0.4, 0.0), YELLOW),
    ("blend patches sorted back to front over green", (-1.0, 0.25, 0.5), BLENDED),
    ("background", (0.0, -1.5, 0.0), BLACK),
]
EXPECTED = [
    COMMON + [("colour-only patch 2: magenta", (1.25, 0.7, 0.0), MAGENTA),
              ("patch 0 below its block's middle row: red", (-1.0, -0.3, 0.0), RED)],
    COMMON + [("patch 2 removed by the delta frame", (1.25, 0.7, 0.0), BLACK),
              ("patch 0's tile repainted white by the delta", (-1.0, -0.3, 0.0), WHITE)],
]


def check_cxx_payloads(chromium, test_binary):
    """C++ encoder -> browser decoder: the atlas texture must match the C++ decoder's image."""
    folder = tempfile.mkdtemp(prefix="mirage-web-fixture-")
    site = os.path.join(folder, "site")
    shutil.copytree(os.path.join(SOURCE, "web"), site)
    env = dict(os.environ, MIRAGE_JPEG_TILES_FIXTURE=site)
    result = subprocess.run([test_binary, "--gtest_filter=JpegTiles.WritesBrowserFixture"], env=env,
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
    if ok:
        shutil.rmtree(folder, ignore_errors=True)
    return ok


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
    if len(sys.argv) > 1 and not check_cxx_payloads(chromium, sys.argv[1]):
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
    if failures:
        print(f"frames kept in {out}")
        return 1
    shutil.rmtree(out, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
