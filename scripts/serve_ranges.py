#!/usr/bin/env python3
"""Serve a directory over HTTP/1.1 with byte ranges, for reading .mrg files by URL where no web
server is installed (docs/asset.md, "Sources"): `mirage render http://127.0.0.1:8000/scene.mrg`.

    python3 scripts/serve_ranges.py DIR [--port 8000] [--bind 127.0.0.1]

GET and HEAD; a single "Range: bytes=A-B" (or "A-", or "-N") gets 206 with Content-Range, anything
else 200 with the whole file; keep-alive connections, one thread each. Python's own http.server
ignores ranges (mirage refuses it for files past the first read). Standard library only.
"""
import argparse
import http.server
import os
import re
import shutil
import socketserver

RANGE = re.compile(r"^bytes=(\d*)-(\d*)$")


class Handler(http.server.SimpleHTTPRequestHandler):
    protocol_version = "HTTP/1.1"  # keep-alive: one connection serves a reader's many page reads

    def log_message(self, format, *args):
        pass

    def send_head(self):
        path = self.translate_path(self.path)
        if not os.path.isfile(path):
            self.send_error(404, "not found")
            return None
        f = open(path, "rb")
        size = os.fstat(f.fileno()).st_size
        start, end = 0, size - 1
        header = self.headers.get("Range")
        m = RANGE.match(header.strip()) if header else None
        if m and (m.group(1) or m.group(2)):
            if m.group(1):
                start = int(m.group(1))
                end = min(int(m.group(2)), size - 1) if m.group(2) else size - 1
            else:
                start = max(size - int(m.group(2)), 0)
            if start > end or start >= size:
                f.close()
                self.send_response(416)
                self.send_header("Content-Range", f"bytes */{size}")
                self.send_header("Content-Length", "0")
                self.end_headers()
                return None
            self.send_response(206)
            self.send_header("Content-Range", f"bytes {start}-{end}/{size}")
        else:
            self.send_response(200)
        self.send_header("Content-Type", "application/octet-stream")
        self.send_header("Accept-Ranges", "bytes")
        self.send_header("Content-Length", str(end - start + 1))
        self.end_headers()
        f.seek(start)
        self.remaining = end - start + 1
        return f

    def copyfile(self, source, outputfile):
        while self.remaining > 0:
            chunk = source.read(min(self.remaining, 1 << 20))
            if not chunk:
                break
            outputfile.write(chunk)
            self.remaining -= len(chunk)


class Server(socketserver.ThreadingMixIn, http.server.HTTPServer):
    daemon_threads = True
    allow_reuse_address = True


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory")
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument("--bind", default="127.0.0.1")
    args = parser.parse_args()
    directory = os.path.abspath(args.directory)

    def handler(*a, **kw):
        return Handler(*a, directory=directory, **kw)

    with Server((args.bind, args.port), handler) as server:
        server.serve_forever()


if __name__ == "__main__":
    main()
