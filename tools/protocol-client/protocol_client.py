#!/usr/bin/env python3
"""A client of the robot's link, written from docs/protocol.md alone.

It reads the page itself: the constants table gives the protocol it speaks, and every
type section (a heading naming the type, then its table of fields or variants) gives
the layout it decodes and encodes by. Then, against a robot on TCP (the virtual robot,
`host-sim serve`), it:

1. checks its own framing against the page's example frame;
2. does the handshake: `Info`, whose reply must name the protocol of every frame's header;
3. sends a frame under another schema hash and expects `VersionMismatch` naming it;
4. pings, reads the configuration and checks that its re-encoding hashes to the
   `params_hash` that `Info` reported (a misread layout changes the bytes);
5. sets the telemetry rate and decodes telemetry frames, checking that each is plausible:
   the step increases, every float is finite, duties are within [-1, 1], the supply is a
   battery's, and the virtual robot's ground truth follows each frame for its step.

It prints `protocol conformance: N telemetry frames decoded from docs/protocol.md` and
exits 0, or names what failed and exits 1 (2 for a bad command line). Python 3.8 or
later, standard library only.
"""

import argparse
import math
import re
import socket
import struct
import sys
import time
import zlib
from pathlib import Path

UNIT = "—"


class Failure(Exception):
    """A check failed; the message says which and why."""


# ---------------------------------------------------------------------------------------
# Reading the page.


def cell_text(cell):
    """A table cell as text: links reduced to their text, backticks gone, spaces collapsed."""
    text = re.sub(r"\[([^\[\]]*)\]\([^)]*\)", r"\1", cell)
    return " ".join(text.replace("`", "").split())


def table_rows(lines, start):
    """The rows (lists of cells) of the table whose header is at `start`, and the line after it."""
    end = start
    while end < len(lines) and lines[end].lstrip().startswith("|"):
        end += 1
    rows = []
    for line in lines[start:end]:
        inner = line.strip().strip("|")
        rows.append([cell_text(c) for c in inner.split("|")])
    # Header, separator, then the rows.
    return rows[0], rows[2:], end


class Page:
    """What docs/protocol.md states: constants, type layouts and the example frame."""

    def __init__(self, text):
        self.constants = {}
        self.structs = {}  # name -> [(field, type expression)]
        self.enums = {}  # name -> [(variant, payload expression)], index = position
        self.example = {}  # part -> bytes
        lines = text.splitlines()
        section = None
        i = 0
        while i < len(lines):
            line = lines[i]
            if line.startswith("#"):
                m = re.fullmatch(r"#+\s*`(\w+)`\s*", line)
                section = m.group(1) if m else None
                i += 1
                continue
            if line.strip().startswith("<!-- example frame"):
                i = self._read_example(lines, i + 1)
                continue
            if not line.lstrip().startswith("|"):
                i += 1
                continue
            header, rows, i = table_rows(lines, i)
            if header[0] == "constant":
                for row in rows:
                    self.constants[row[0]] = row[1]
            elif header[0] == "field" and section:
                self.structs[section] = [(r[0], r[1]) for r in rows]
            elif header[0] == "index" and section:
                for position, row in enumerate(rows):
                    if row[0] != str(position):
                        raise Failure(f"page: `{section}` row {position} states index {row[0]}")
                self.enums[section] = [(r[1], r[2]) for r in rows]
            section = None

    def _read_example(self, lines, i):
        while not lines[i].lstrip().startswith("```"):
            i += 1
        i += 1
        while not lines[i].lstrip().startswith("```"):
            name, _, hex_bytes = lines[i].partition(":")
            self.example[name.strip()] = bytes.fromhex(hex_bytes)
            i += 1
        return i + 1

    def number(self, name):
        """A constant of the page as an integer (decimal, or hex after 0x)."""
        text = self.constants[name].replace(" ", "")
        return int(text, 16) if text.startswith("0x") else int(text)


# ---------------------------------------------------------------------------------------
# Type expressions: `u32`, `Option<T>`, `Vec<T>`, `Result<T, E>`, `(A, B)`,
# `{ a: T, b: U }`, `—`, or a type's name.


def split_top(text, separator=","):
    """`text` split at `separator`s outside <>, () and {}."""
    parts, depth, current = [], 0, ""
    for c in text:
        if c in "<({":
            depth += 1
        elif c in ">)}":
            depth -= 1
        if c == separator and depth == 0:
            parts.append(current.strip())
            current = ""
        else:
            current += c
    if current.strip():
        parts.append(current.strip())
    return parts


def parse_type(text):
    """A type expression as a tree of tuples."""
    text = text.strip()
    if text == UNIT:
        return ("unit",)
    if text.startswith("{") and text.endswith("}"):
        fields = []
        for part in split_top(text[1:-1]):
            name, _, ty = part.partition(":")
            fields.append((name.strip(), parse_type(ty)))
        return ("fields", fields)
    if text.startswith("(") and text.endswith(")"):
        return ("tuple", [parse_type(p) for p in split_top(text[1:-1])])
    m = re.fullmatch(r"(Option|Vec|Result)<(.*)>", text)
    if m:
        args = [parse_type(p) for p in split_top(m.group(2))]
        return (m.group(1).lower(), *args)
    return ("named", text)


class Reader:
    """Decodes postcard bytes by the page's rules."""

    def __init__(self, page, data):
        self.page, self.data, self.pos = page, data, 0

    def byte(self):
        if self.pos >= len(self.data):
            raise Failure("body ended early")
        b = self.data[self.pos]
        self.pos += 1
        return b

    def varint(self, max_bytes):
        value, shift = 0, 0
        for _ in range(max_bytes):
            b = self.byte()
            value |= (b & 0x7F) << shift
            if b < 0x80:
                return value
            shift += 7
        raise Failure("varint too long")

    def take(self, n):
        if self.pos + n > len(self.data):
            raise Failure("body ended early")
        chunk = self.data[self.pos : self.pos + n]
        self.pos += n
        return chunk

    def value(self, ty):
        kind = ty[0]
        if kind == "unit":
            return None
        if kind == "fields":
            return {name: self.value(t) for name, t in ty[1]}
        if kind == "tuple":
            return [self.value(t) for t in ty[1]]
        if kind == "option":
            tag = self.byte()
            if tag == 0:
                return None
            if tag == 1:
                return self.value(ty[1])
            raise Failure(f"Option tag {tag}")
        if kind == "vec":
            return [self.value(ty[1]) for _ in range(self.varint(5))]
        if kind == "result":
            index = self.varint(5)
            if index > 1:
                raise Failure(f"Result index {index}")
            return {"variant": ("Ok", "Err")[index], "value": self.value(ty[1 + index])}
        return self.named(ty[1])

    def named(self, name):
        if name == "bool":
            b = self.byte()
            if b > 1:
                raise Failure(f"bool byte {b}")
            return b == 1
        if name in ("u8", "i8"):
            b = self.byte()
            return b - 256 if name == "i8" and b > 127 else b
        widths = {"16": 3, "32": 5, "64": 10}
        if name[0] == "u" and name[1:] in widths:
            return self.varint(widths[name[1:]])
        if name[0] == "i" and name[1:] in widths:
            n = self.varint(widths[name[1:]])
            return (n >> 1) ^ -(n & 1)
        if name == "f32":
            return struct.unpack("<f", self.take(4))[0]
        if name == "f64":
            return struct.unpack("<d", self.take(8))[0]
        if name == "String":
            raw = self.take(self.varint(5))
            try:
                return raw.decode("utf-8")
            except UnicodeDecodeError as e:
                raise Failure(f"string not UTF-8: {e}") from None
        if name in self.page.structs:
            return {f: self.value(parse_type(t)) for f, t in self.page.structs[name]}
        if name in self.page.enums:
            variants = self.page.enums[name]
            index = self.varint(5)
            if index >= len(variants):
                raise Failure(f"`{name}` has no variant {index}")
            variant, payload = variants[index]
            return {"variant": variant, "value": self.value(parse_type(payload))}
        raise Failure(f"the page has no section for `{name}`")


class Writer:
    """Encodes values (as `Reader` returns them) by the page's rules."""

    def __init__(self, page):
        self.page, self.out = page, bytearray()

    def varint(self, n):
        while True:
            if n < 0x80:
                self.out.append(n)
                return
            self.out.append((n & 0x7F) | 0x80)
            n >>= 7

    def value(self, ty, v):
        kind = ty[0]
        if kind == "unit":
            return
        if kind == "fields":
            for name, t in ty[1]:
                self.value(t, v[name])
        elif kind == "tuple":
            for t, item in zip(ty[1], v):
                self.value(t, item)
        elif kind == "option":
            if v is None:
                self.out.append(0)
            else:
                self.out.append(1)
                self.value(ty[1], v)
        elif kind == "vec":
            self.varint(len(v))
            for item in v:
                self.value(ty[1], item)
        elif kind == "result":
            index = ("Ok", "Err").index(v["variant"])
            self.varint(index)
            self.value(ty[1 + index], v["value"])
        else:
            self.named(ty[1], v)

    def named(self, name, v):
        if name == "bool":
            self.out.append(1 if v else 0)
        elif name in ("u8", "i8"):
            self.out.append(v & 0xFF)
        elif name[0] == "u" and name[1:] in ("16", "32", "64"):
            self.varint(v)
        elif name[0] == "i" and name[1:] in ("16", "32", "64"):
            bits = int(name[1:])
            self.varint(((v << 1) ^ (v >> (bits - 1))) & ((1 << bits) - 1))
        elif name == "f32":
            self.out += struct.pack("<f", v)
        elif name == "f64":
            self.out += struct.pack("<d", v)
        elif name == "String":
            raw = v.encode("utf-8")
            self.varint(len(raw))
            self.out += raw
        elif name in self.page.structs:
            for f, t in self.page.structs[name]:
                self.value(parse_type(t), v[f])
        elif name in self.page.enums:
            variants = self.page.enums[name]
            index = [n for n, _ in variants].index(v["variant"])
            self.varint(index)
            self.value(parse_type(variants[index][1]), v.get("value"))
        else:
            raise Failure(f"the page has no section for `{name}`")


def encode(page, type_name, value):
    w = Writer(page)
    w.named(type_name, value)
    return bytes(w.out)


def decode(page, type_name, body):
    r = Reader(page, body)
    value = r.named(type_name)
    if r.pos != len(body):
        raise Failure(f"{len(body) - r.pos} bytes left over after a `{type_name}`")
    return value


# ---------------------------------------------------------------------------------------
# Frames: header, CRC-32, COBS, delimiter.


def cobs_encode(data):
    out, block = bytearray(), bytearray()
    for b in data:
        if b == 0:
            out.append(len(block) + 1)
            out += block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out.append(255)
                out += block
                block = bytearray()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def cobs_decode(data):
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            raise Failure("invalid COBS")
        out += data[i + 1 : i + code]
        i += code
        if code < 255 and i < len(data):
            out.append(0)
    return bytes(out)


def header(version, schema_hash):
    return bytes([version]) + struct.pack("<I", schema_hash)


def frame(head, body):
    payload = head + body
    return cobs_encode(payload + struct.pack("<I", zlib.crc32(payload))) + b"\x00"


def unframe(page, stuffed):
    """(header bytes, body) of one frame without its delimiter."""
    raw = cobs_decode(stuffed)
    head_len, crc_len = page.number("HEADER_LEN"), page.number("CRC_LEN")
    if len(raw) < head_len + 1 + crc_len:
        raise Failure("frame too short")
    payload, crc = raw[:-crc_len], struct.unpack("<I", raw[-crc_len:])[0]
    if zlib.crc32(payload) != crc:
        raise Failure("CRC mismatch")
    return payload[:head_len], payload[head_len:]


def check_example(page):
    """Our framing against the page's example (its message is `Downlink { seq: 300, Ping { nonce: 0 } }`)."""
    ping = {"seq": 300, "request": {"variant": "Ping", "value": {"nonce": 0}}}
    body = encode(page, "Downlink", ping)
    head = header(1, 0x01020304)
    ours = {
        "body": body,
        "header": head,
        "crc": struct.pack("<I", zlib.crc32(head + body)),
        "frame": frame(head, body),
    }
    for part, expected in page.example.items():
        if ours.get(part) != expected:
            raise Failure(f"example frame: our `{part}` is {ours.get(part, b'').hex(' ')}, the page's {expected.hex(' ')}")
    if decode(page, "Downlink", body) != ping:
        raise Failure("example frame: the body does not decode back")


# ---------------------------------------------------------------------------------------
# The session.


class Link:
    def __init__(self, page, address, timeout_s):
        host, _, port = address.rpartition(":")
        self.page = page
        self.sock = socket.create_connection((host, int(port)), timeout=timeout_s)
        self.timeout_s = timeout_s
        self.buffer = bytearray()
        self.ours = header(page.number("PROTOCOL_VERSION"), page.number("SCHEMA_HASH"))
        self.seq = 0
        self.sock.sendall(b"\x00")

    def send(self, request, head=None):
        self.seq = (self.seq + 1) & 0xFFFF
        body = encode(self.page, "Downlink", {"seq": self.seq, "request": request})
        self.sock.sendall(frame(head or self.ours, body))
        return self.seq

    def messages(self):
        """Every `Uplink` the robot sends, decoded, until the timeout passes with none."""
        while True:
            while b"\x00" not in self.buffer:
                try:
                    chunk = self.sock.recv(4096)
                except socket.timeout:
                    raise Failure(f"nothing from the robot for {self.timeout_s} s") from None
                if not chunk:
                    raise Failure("the robot closed the connection")
                self.buffer += chunk
            end = self.buffer.index(0)
            stuffed, self.buffer = bytes(self.buffer[:end]), self.buffer[end + 1 :]
            if not stuffed:
                continue
            head, body = unframe(self.page, stuffed)
            if head != self.ours:
                version, schema = head[0], struct.unpack("<I", head[1:])[0]
                raise Failure(
                    f"robot speaks protocol v{version} schema 0x{schema:08x}, this client "
                    f"protocol v{self.ours[0]} schema 0x{struct.unpack('<I', self.ours[1:])[0]:08x}"
                )
            try:
                message = decode(self.page, "Uplink", body)
            except Failure as e:
                raise Failure(f"decoding {self.describe(body)} from the robot: {e}") from None
            yield message

    def describe(self, body):
        """`Uplink::NAME`, from the variant index that starts `body`."""
        try:
            index = Reader(self.page, body).varint(5)
            return f"Uplink::{self.page.enums['Uplink'][index][0]}"
        except (Failure, IndexError):
            return "a frame"

    def reply(self, seq, seen=None):
        """The reply to `seq`; what arrives meanwhile goes to `seen`."""
        deadline = time.monotonic() + 5 * self.timeout_s
        for message in self.messages():
            if message["variant"] == "Reply" and message["value"]["seq"] == seq:
                return message["value"]["result"]
            if seen is not None:
                seen.append(message)
            if time.monotonic() > deadline:
                break
        raise Failure(f"no reply to request {seq}")

    def request(self, request, expect):
        result = self.reply(self.send(request))
        if result["variant"] != "Ok" or result["value"]["variant"] != expect:
            raise Failure(f"{request['variant']}: expected Ok({expect}), got {result}")
        return result["value"]["value"]


def finite(value, where):
    """Every float in `value` is finite."""
    if isinstance(value, float):
        if not math.isfinite(value):
            raise Failure(f"{where} is {value}")
    elif isinstance(value, dict):
        for k, v in value.items():
            finite(v, f"{where}.{k}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            finite(v, f"{where}[{i}]")


def check_telemetry(t, previous_step):
    where = f"telemetry at step {t['step']}"
    finite(t, where)
    if previous_step is not None and t["step"] <= previous_step:
        raise Failure(f"{where}: the step did not increase (after {previous_step})")
    for side in ("left", "right"):
        if not -1.0 <= t["duty"][side] <= 1.0:
            raise Failure(f"{where}: duty.{side} {t['duty'][side]} is outside [-1, 1]")
    if not 1.0 < t["supply_v"] < 30.0:
        raise Failure(f"{where}: supply_v {t['supply_v']} V is not a battery's")
    if abs(t["pose"]["theta_rad"]) > math.pi + 1e-6:
        raise Failure(f"{where}: pose.theta_rad {t['pose']['theta_rad']} is not wrapped")
    flags = dict(t["faults"])
    flags.update(flags.pop("core"))
    if any(flags.values()) != (t["state"]["variant"] == "Faulted"):
        raise Failure(f"{where}: faults {flags} disagree with the state {t['state']['variant']}")


def run(page_path, address, frames, hz, timeout_s):
    page = Page(Path(page_path).read_text(encoding="utf-8"))
    check_example(page)
    link = Link(page, address, timeout_s)

    # The handshake.
    info = link.request({"variant": "Info"}, "Info")
    ours = {"version": page.number("PROTOCOL_VERSION"), "schema_hash": page.number("SCHEMA_HASH")}
    if info["protocol"] != ours:
        raise Failure(f"Info names {info['protocol']}, the frame headers {ours}")
    if not info["firmware_version"] or not info["chip"]:
        raise Failure(f"Info has an empty firmware version or chip: {info}")

    # Another protocol's frame is answered with VersionMismatch naming it.
    other = {"version": ours["version"], "schema_hash": ours["schema_hash"] ^ 0xFFFFFFFF}
    link.send({"variant": "Ping", "value": {"nonce": 1}}, head=header(other["version"], other["schema_hash"]))
    for message in link.messages():
        if message["variant"] == "VersionMismatch":
            if message["value"]["received"] != other:
                raise Failure(f"VersionMismatch names {message['value']['received']}, we sent {other}")
            break

    pong = link.request({"variant": "Ping", "value": {"nonce": 4_000_000_000}}, "Pong")
    if pong["nonce"] != 4_000_000_000:
        raise Failure(f"Pong carries {pong['nonce']}")

    # The configuration, re-encoded, must hash as the robot says.
    params = link.request({"variant": "GetParams"}, "Params")
    finite(params, "params")
    ours_hash = zlib.crc32(encode(page, "ParamSet", params))
    if ours_hash != info["params_hash"]:
        raise Failure(f"the configuration re-encodes to hash 0x{ours_hash:08x}, Info says 0x{info['params_hash']:08x}")

    # Telemetry.
    link.request({"variant": "SetTelemetryRate", "value": {"hz": hz}}, "Ack")
    decoded, previous, truth_for = 0, None, None
    for message in link.messages():
        kind, value = message["variant"], message["value"]
        if kind == "Telemetry":
            check_telemetry(value, previous)
            previous, truth_for = value["step"], value["step"]
            decoded += 1
            if decoded == frames:
                break
        elif kind == "GroundTruth":
            finite(value, "ground truth")
            if value["step"] != truth_for:
                raise Failure(f"ground truth for step {value['step']} follows telemetry of step {truth_for}")
    return decoded


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", required=True, help="the robot's TCP address, e.g. 127.0.0.1:5760")
    parser.add_argument("--page", default=str(Path(__file__).resolve().parents[2] / "docs" / "protocol.md"))
    parser.add_argument("--frames", type=int, default=100, help="telemetry frames to decode")
    parser.add_argument("--hz", type=int, default=100, help="telemetry rate to ask for")
    parser.add_argument("--timeout-s", type=float, default=5.0)
    args = parser.parse_args()
    try:
        n = run(args.page, args.connect, args.frames, args.hz, args.timeout_s)
    except (Failure, OSError, KeyError, ValueError) as e:
        print(f"protocol conformance FAILED: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    print(f"protocol conformance: {n} telemetry frames decoded from docs/protocol.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
