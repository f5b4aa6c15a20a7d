"""A WebSocket client (RFC 6455) on a plain socket, for the live route's tests: the handshake, masked
frames (whole, split, or broken on purpose), and the server's messages read back with their opcodes."""
import base64
import hashlib
import json
import os
import socket
import struct

GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"
TEXT, BINARY, CLOSE, PING, PONG = 1, 2, 8, 9, 10


class Closed(Exception):
    """The server closed: its close code and reason (code 1006: the socket ended without a close frame)."""

    def __init__(self, code, reason):
        super().__init__(f"closed {code}: {reason}")
        self.code, self.reason = code, reason


def frame(opcode, payload, fin=True, mask=True, rsv=0):
    """A client frame; `mask=False` or `rsv` make a broken one."""
    head = bytes([(0x80 if fin else 0) | rsv << 4 | opcode])
    n = len(payload)
    m = 0x80 if mask else 0
    if n < 126:
        head += bytes([m | n])
    elif n < 65536:
        head += bytes([m | 126]) + struct.pack(">H", n)
    else:
        head += bytes([m | 127]) + struct.pack(">Q", n)
    if not mask:
        return head + payload
    key = os.urandom(4)
    return head + key + bytes(b ^ key[i & 3] for i, b in enumerate(payload))


class Client:
    def __init__(self, port, path, host="127.0.0.1", headers=None, timeout=10, source=None):
        """`source`: the client's own address (127.0.0.x: another client to the server's caps)."""
        self.sock = socket.create_connection((host, port), timeout=timeout, source_address=(source, 0) if source else None)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        key = base64.b64encode(os.urandom(16)).decode()
        head = f"GET {path} HTTP/1.1\r\n"
        fields = {"Host": host, "Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Key": key, "Sec-WebSocket-Version": "13"}
        fields.update(headers or {})
        for k, v in fields.items():
            head += f"{k}: {v}\r\n"
        self.sock.sendall((head + "\r\n").encode())
        self.buf = b""
        while b"\r\n\r\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise Closed(1006, "no answer to the handshake")
            self.buf += chunk
        end = self.buf.index(b"\r\n\r\n") + 4
        self.head = self.buf[:end].decode("latin-1")
        self.buf = self.buf[end:]
        self.status = int(self.head.split()[1])
        self.headers = {l.split(":", 1)[0].lower(): l.split(":", 1)[1].strip() for l in self.head.split("\r\n")[1:] if ":" in l}
        if self.status == 101:
            want = base64.b64encode(hashlib.sha1((key + GUID).encode()).digest()).decode()
            assert self.headers.get("sec-websocket-accept") == want, self.head

    def send_raw(self, data):
        self.sock.sendall(data)

    def send_text(self, obj):
        self.sock.sendall(frame(TEXT, (obj if isinstance(obj, str) else json.dumps(obj)).encode()))

    def _need(self, n):
        while len(self.buf) < n:
            chunk = self.sock.recv(1 << 20)
            if not chunk:
                raise Closed(1006, "the socket ended")
            self.buf += chunk

    def recv(self):
        """(opcode, payload) of the server's next message; a close frame raises Closed."""
        self._need(2)
        b0, b1 = self.buf[0], self.buf[1]
        assert not b1 & 0x80, "a server frame must not be masked"
        n, at = b1 & 0x7F, 2
        if n == 126:
            self._need(4)
            n, at = struct.unpack(">H", self.buf[2:4])[0], 4
        elif n == 127:
            self._need(10)
            n, at = struct.unpack(">Q", self.buf[2:10])[0], 10
        self._need(at + n)
        payload, self.buf = self.buf[at:at + n], self.buf[at + n:]
        op = b0 & 0x0F
        if op == CLOSE:
            code = struct.unpack(">H", payload[:2])[0] if len(payload) >= 2 else 1005
            raise Closed(code, payload[2:].decode("utf-8", "replace"))
        return op, payload

    def recv_json(self, event=None):
        """The next text message (skipping binary ones), or the next of `event`."""
        while True:
            op, payload = self.recv()
            if op == TEXT:
                m = json.loads(payload)
                if event is None or m.get("event") == event:
                    return m

    def recv_frame(self):
        """The next binary mesh frame: (frame number, id, payload after the 16-byte header)."""
        while True:
            op, payload = self.recv()
            if op == BINARY:
                assert payload[:4] == b"mesh", payload[:16]
                number, ident = struct.unpack("<II", payload[4:12])
                return number, ident, payload[16:]

    def close(self):
        try:
            self.sock.sendall(frame(CLOSE, struct.pack(">H", 1000)))
        except OSError:
            pass
        self.sock.close()
