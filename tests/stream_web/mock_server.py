"""A stand-in for `mirage serve` in the browser test: serves a folder over HTTP and speaks the stream
protocol (include/mirage/stream/protocol.h, byte layout in src/stream/protocol.cpp) on the same port
over WebSocket. It checks the page's Hello and Poses field by field and answers each Pose with a
scripted Frame. Python standard library only.
"""
import base64
import functools
import hashlib
import http.server
import struct
import threading

WS_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"
HEADER = struct.Struct("<4sHHI")
HELLO, WELCOME, POSE, FRAME, CLOSE = 1, 2, 3, 4, 5
CAPABILITY_JPEG_TILES = 1 << 2
CODEC_NONE, CODEC_JPEG_TILES = 0, 3


VERSION = 3
# The position grid of the mock scene: Welcome.positionStep over scene_min (exact in float32).
POSITION_STEP = 1 / 1024


def message(kind, payload):
    return HEADER.pack(b"MRGS", VERSION, kind, len(payload)) + payload


def welcome(scene_min, scene_max, atlas_width, atlas_height, patch_count):
    return message(WELCOME, struct.pack("<Q3f3ffIIBIII", 42, *scene_min, *scene_max, POSITION_STEP, atlas_width,
                                        atlas_height, CODEC_JPEG_TILES, patch_count, 1 << 24, 0))


def varint(v):
    out = bytearray()
    while v >= 0x80:
        out.append(v & 0x7F | 0x80)
        v >>= 7
    out.append(v)
    return bytes(out)


def zigzag(v):
    return -2 * v - 1 if v < 0 else 2 * v


def predict(q, slot, k, previous_a):
    """Grid coordinate k of slot `slot` as predicted (patch_section.cpp): a from the previous geometry
    entry's a, b and c from a, d = b + c - a, e = b + d - c."""
    if slot == 0:
        return previous_a[k]
    if slot <= 2:
        return q[0][k]
    if slot == 3:
        return q[1][k] + q[2][k] - q[0][k]
    return q[1][k] + q[3][k] - q[2][k]


def frame(sequence, pose_sequence, removed, updated, colours, atlas, scene_min):
    """A Frame with a raw patch section (src/stream/patch_section.cpp). updated: dicts id, triangles,
    alpha, log2, x, y and positions (world, quantized on the grid over scene_min), or geometry=False for
    a block-only entry; ids increasing in each list. colours: (id, (r, g, b, a)); atlas: (codec, width,
    height, bytes)."""
    section = bytearray(varint(len(removed)))
    next_id = 0
    for i in removed:
        section += varint(i - next_id)
        next_id = i + 1
    section += varint(len(updated))
    next_id, previous_a = 0, (0, 0, 0)
    for p in updated:
        geometry, colour_only = p.get("geometry", True), p["log2"] == 255
        section += varint(p["id"] - next_id)
        next_id = p["id"] + 1
        section.append(p["triangles"] | (p["alpha"] << 2 | 0x10 if geometry else 0) | (0x20 if colour_only else 0))
        if not colour_only:
            section += bytes([p["log2"]]) + varint(p["x"] >> p["log2"]) + varint(p["y"] >> p["log2"])
        if not geometry:
            continue
        q = [[round((v[k] - scene_min[k]) / POSITION_STEP) for k in range(3)] for v in p["positions"]]
        for i, v in enumerate(q):
            for k in range(3):
                section += varint(zigzag(v[k] - predict(q, i, k, previous_a)))
        previous_a = q[0]
    section += varint(len(colours))
    next_id = 0
    for i, rgba in colours:
        section += varint(i - next_id) + bytes(rgba)
        next_id = i + 1
    out = struct.pack("<IIQBI", sequence, pose_sequence, 0, 0, len(section)) + section
    out += struct.pack("<BI", 0, 2) + bytes([0, 0])  # the particle section: raw, no looks, no particles
    codec, width, height, data = atlas
    out += struct.pack("<BIII", codec, width, height, len(data)) + data
    return message(FRAME, out)


def parse_client_message(data):
    """(type, fields) of a Hello or Pose; raises ValueError naming the problem."""
    if len(data) < HEADER.size:
        raise ValueError(f"message of {len(data)} bytes")
    magic, version, kind, length = HEADER.unpack_from(data)
    if magic != b"MRGS" or version != VERSION or length != len(data) - HEADER.size:
        raise ValueError(f"bad header {magic!r} version {version} length {length} of {len(data) - HEADER.size}")
    payload = data[HEADER.size:]
    if kind == HELLO:
        (n,) = struct.unpack_from("<H", payload)
        token = payload[2:2 + n].decode()
        capabilities, width, height, stereo = struct.unpack_from("<IIIB", payload, 2 + n)
        if len(payload) != 2 + n + 13:
            raise ValueError(f"Hello of {len(payload)} bytes")
        return kind, dict(token=token, capabilities=capabilities, width=width, height=height, stereo=stereo)
    if kind == POSE:
        if len(payload) != 100:
            raise ValueError(f"Pose of {len(payload)} bytes, expected 100")
        sequence, time_us = struct.unpack_from("<IQ", payload)
        camera = struct.unpack_from("<10f", payload, 12)
        predicted = struct.unpack_from("<10f", payload, 52)
        width, height = struct.unpack_from("<II", payload, 92)
        return kind, dict(sequence=sequence, time_us=time_us, camera=camera, predicted=predicted, width=width,
                          height=height)
    raise ValueError(f"message type {kind} not expected from a client")


class WebSocket:
    """The server half of RFC 6455 on a handler's streams: binary frames, client frames masked."""

    def __init__(self, handler):
        self.rfile, self.wfile = handler.rfile, handler.wfile

    def receive(self):
        data = b""
        while True:
            head = self.rfile.read(2)
            if len(head) < 2:
                return None  # the page went away
            b0, b1 = head
            n = b1 & 0x7F
            if n == 126:
                (n,) = struct.unpack(">H", self.rfile.read(2))
            elif n == 127:
                (n,) = struct.unpack(">Q", self.rfile.read(8))
            mask = self.rfile.read(4) if b1 & 0x80 else b"\0\0\0\0"
            payload = bytes(b ^ mask[i % 4] for i, b in enumerate(self.rfile.read(n)))
            if b0 & 0x0F == 0x8:
                return None
            data += payload
            if b0 & 0x80:
                return data

    def send(self, data):
        n = len(data)
        head = bytes([0x82]) + (bytes([n]) if n < 126 else
                                bytes([126]) + struct.pack(">H", n) if n < 1 << 16 else
                                bytes([127]) + struct.pack(">Q", n))
        self.wfile.write(head + data)
        self.wfile.flush()


def serve(directory, script):
    """Starts the server in a daemon thread. `script(kind, fields, log)` returns the messages (bytes)
    to send for each client message; what it appends to `log` (and any problem) the caller reads
    from server.log / server.problems."""

    class Handler(http.server.SimpleHTTPRequestHandler):
        extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, ".js": "text/javascript"}

        def log_message(self, *args):
            pass

        def do_GET(self):
            if self.headers.get("Upgrade", "").lower() != "websocket":
                return super().do_GET()
            accept = base64.b64encode(hashlib.sha1((self.headers["Sec-WebSocket-Key"] + WS_GUID).encode()).digest())
            self.send_response(101)
            self.send_header("Upgrade", "websocket")
            self.send_header("Connection", "Upgrade")
            self.send_header("Sec-WebSocket-Accept", accept.decode())
            self.end_headers()
            self.wfile.flush()
            socket = WebSocket(self)
            try:
                while (data := socket.receive()) is not None:
                    kind, fields = parse_client_message(data)
                    for reply in script(kind, fields, server.log):
                        socket.send(reply)
            except (ValueError, struct.error, ConnectionError) as e:
                server.problems.append(str(e))
            self.close_connection = True

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=directory))
    server.log, server.problems = [], []
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server
