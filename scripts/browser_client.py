#!/usr/bin/env python3
"""Runs the browser client (web/) in headless Chromium and saves the frames it records.

The page (web/index.html?path=...&record=1, or web/test.html) writes its progress into
document.title ("frame 3/10", then "done 10" or "error: ...") and each frame's pixels into
window.mirageFrames[] as PNG data URLs. This script starts Chromium with the DevTools protocol on a
local port, polls the title through a minimal WebSocket client (Python standard library only), and
writes frame_0000.png, frame_0001.png, ... into --out.

  scripts/browser_client.py 'http://host:8080/?path=cams.json&record=1#token=...' --out frames/
  scripts/browser_client.py --serve web test.html --out frames/   # a local static server for web/

Exit status: 0 done, 1 the page reported an error or timed out, 2 Chromium missing or failed to start.
"""
import argparse
import base64
import functools
import http.client
import http.server
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib


class DevToolsSocket:
    """The client half of RFC 6455, enough for the DevTools protocol: masked text frames out,
    unmasked (possibly fragmented, possibly 64-bit length) frames in."""

    def __init__(self, url, timeout):
        assert url.startswith("ws://"), url
        host_port, _, path = url[len("ws://"):].partition("/")
        host, _, port = host_port.partition(":")
        self.sock = socket.create_connection((host, int(port or 80)), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        request = (f"GET /{path} HTTP/1.1\r\nHost: {host_port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                   f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n")
        self.sock.sendall(request.encode())
        response = b""
        while b"\r\n\r\n" not in response:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("DevTools closed the connection during the WebSocket handshake")
            response += chunk
        head, _, self.buffer = response.partition(b"\r\n\r\n")
        if b" 101 " not in head.split(b"\r\n")[0]:
            raise ConnectionError(f"DevTools refused the WebSocket: {head.splitlines()[0].decode()}")
        self.next_id = 0

    def _read(self, n):
        while len(self.buffer) < n:
            chunk = self.sock.recv(1 << 20)
            if not chunk:
                raise ConnectionError("DevTools closed the connection")
            self.buffer += chunk
        out, self.buffer = self.buffer[:n], self.buffer[n:]
        return out

    def send_text(self, text):
        payload = text.encode()
        header = bytes([0x81])
        n = len(payload)
        if n < 126:
            header += bytes([0x80 | n])
        elif n < 1 << 16:
            header += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            header += bytes([0x80 | 127]) + struct.pack(">Q", n)
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(header + mask + masked)

    def receive_text(self):
        message = b""
        while True:
            b0, b1 = self._read(2)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack(">H", self._read(2))[0]
            elif n == 127:
                n = struct.unpack(">Q", self._read(8))[0]
            mask = self._read(4) if b1 & 0x80 else None
            payload = self._read(n)
            if mask:
                payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
            opcode = b0 & 0x0F
            if opcode == 0x8:
                raise ConnectionError("DevTools closed the WebSocket")
            if opcode in (0x9, 0xA):  # ping / pong: not used by DevTools, skipped
                continue
            message += payload
            if b0 & 0x80:
                return message.decode()

    def call(self, method, **params):
        self.next_id += 1
        self.send_text(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            reply = json.loads(self.receive_text())
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error'].get('message')}")
                return reply.get("result", {})

    def evaluate(self, expression):
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails'].get('text')}")
        return result["result"].get("value")


def find_chromium(explicit):
    for name in [explicit] if explicit else ["chromium", "chromium-browser", "google-chrome"]:
        path = shutil.which(name) if name else None
        if path:
            return path
    return None


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve_directory(directory):
    """A static HTTP server for `directory` on a free local port, in a daemon thread."""

    class Handler(http.server.SimpleHTTPRequestHandler):
        # ES modules load only with a JavaScript MIME type.
        extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, ".js": "text/javascript"}

        def log_message(self, *args):
            pass

    handler = functools.partial(Handler, directory=directory)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def devtools_page(port, deadline):
    """The WebSocket URL of the page target, once Chromium's DevTools endpoint answers."""
    while time.time() < deadline:
        try:
            connection = http.client.HTTPConnection("127.0.0.1", port, timeout=2)
            connection.request("GET", "/json/list")
            targets = json.loads(connection.getresponse().read())
            for target in targets:
                if target.get("type") == "page" and "webSocketDebuggerUrl" in target:
                    return target["webSocketDebuggerUrl"]
        except (OSError, ValueError, http.client.HTTPException):
            pass
        time.sleep(0.2)
    return None


def run(url, out_dir, chromium, timeout, width, height, log):
    port = free_port()
    profile = tempfile.mkdtemp(prefix="mirage-chromium-")
    args = [chromium, "--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
            "--ignore-gpu-blocklist", f"--remote-debugging-port={port}", f"--user-data-dir={profile}",
            f"--window-size={width},{height}", "--no-first-run", "--no-default-browser-check", url]
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.time() + timeout
        page = devtools_page(port, deadline)
        if not page:
            err = process.stderr.read().decode(errors="replace") if process.poll() is not None else ""
            print(f"browser_client: {chromium} did not open DevTools on port {port} {err.strip()[:300]}",
                  file=sys.stderr)
            return 2
        devtools = DevToolsSocket(page, timeout=30)
        title = ""
        while time.time() < deadline:
            title = devtools.evaluate("document.title") or ""
            if title.startswith("done") or title.startswith("error"):
                break
            time.sleep(0.2)
        count = devtools.evaluate("(window.mirageFrames || []).length") or 0
        os.makedirs(out_dir, exist_ok=True)
        for i in range(count):
            data_url = devtools.evaluate(f"window.mirageFrames[{i}] || ''")
            if not data_url.startswith("data:image/png;base64,"):
                continue
            with open(os.path.join(out_dir, f"frame_{i:04d}.png"), "wb") as f:
                f.write(base64.b64decode(data_url.split(",", 1)[1]))
        log(f"browser_client: '{title}', {count} frames written to {out_dir}")
        if not title.startswith("done"):
            reason = title if title.startswith("error") else f"timed out after {timeout} s at '{title}'"
            print(f"browser_client: {url}: {reason}", file=sys.stderr)
            return 1
        return 0
    finally:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
        shutil.rmtree(profile, ignore_errors=True)


def read_png(path):
    """(width, height, rows of RGBA bytes) of an 8-bit RGB/RGBA non-interlaced PNG (what Chromium writes)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, width, height, colour = 8, b"", 0, 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise ValueError(f"{path}: PNG depth {depth} colour type {colour} interlace {interlace} not handled")
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    channels = 4 if colour == 6 else 3
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous = [], bytearray(stride)
    for y in range(height):
        filter_type = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            left = line[i - channels] if i >= channels else 0
            up = previous[i]
            upper_left = previous[i - channels] if i >= channels else 0
            if filter_type == 1:
                line[i] = (line[i] + left) & 0xFF
            elif filter_type == 2:
                line[i] = (line[i] + up) & 0xFF
            elif filter_type == 3:
                line[i] = (line[i] + (left + up) // 2) & 0xFF
            elif filter_type == 4:
                p = left + up - upper_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - upper_left)
                predictor = left if pa <= pb and pa <= pc else (up if pb <= pc else upper_left)
                line[i] = (line[i] + predictor) & 0xFF
        previous = line
        if channels == 3:
            line = bytearray(b for i in range(width) for b in (*line[3 * i:3 * i + 3], 255))
        rows.append(bytes(line))
    return width, height, rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("url", help="page URL, or a path inside --serve's directory")
    parser.add_argument("--out", default="browser_frames", help="folder for frame_NNNN.png")
    parser.add_argument("--serve", metavar="DIR", help="serve DIR over local HTTP and open the page from it")
    parser.add_argument("--chromium", help="browser binary (default: chromium on PATH)")
    parser.add_argument("--timeout", type=float, default=120, help="seconds until the page must say done")
    parser.add_argument("--width", type=int, default=800)
    parser.add_argument("--height", type=int, default=600)
    args = parser.parse_args()
    chromium = find_chromium(args.chromium)
    if not chromium:
        print("browser_client: chromium not found (scripts/setup installs it)", file=sys.stderr)
        return 2
    url = args.url
    server = None
    if args.serve:
        server = serve_directory(args.serve)
        url = f"http://127.0.0.1:{server.server_address[1]}/{url.lstrip('/')}"
    try:
        return run(url, args.out, chromium, args.timeout, args.width, args.height, print)
    finally:
        if server:
            server.shutdown()


if __name__ == "__main__":
    sys.exit(main())
