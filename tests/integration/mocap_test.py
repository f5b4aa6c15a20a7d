#!/usr/bin/env python3
"""The live socket and the apps VTubers stream with (issue 64): VMC out and in, iFacialMocap in, against the real
server on loopback, with Debian's liblo-tools (oscdump, oscsend) as the independent OSC tool on the other end.

  mocap_test.py FACESPACE_BIN SOURCE_DIR [release|sanitized]

- {"vmc": {"port": P}}: oscdump on P prints every frame's /VMC/Ext/Blend/Val values (ARKit's 52, VRM 0.x's presets)
  and one /VMC/Ext/Blend/Apply a frame, as many Applies as frames the socket got, the last frame's values the
  weights set (jawOpen 0.6 is jawOpen 0.6; eyeBlink_L 1 is eyeBlinkLeft 1 and the Blink_L preset);
- {"listen_vmc": {"port": 0}}: oscsend's /VMC/Ext/Blend/Val jawOpen 0.7 then Apply moves FaceCap to POST /mesh's
  face of jawOpen 0.7, byte for byte; VRM 0.x's Joy smiles as "vocabulary": "vrm" with happy 1 does (positions
  within 2% of its move);
- {"listen_ifacialmocap": {"port": 0}}: an iPhone's line (jawOpen-50|eyeBlink_L-100|=head#...) moves it as
  "vocabulary": "arkit" with jawOpen 0.5 and eyeBlink_L 1 would;
- hostile: garbage and truncated OSC (an error event), a datagram of 65,000 bytes, floods of garbage and of whole
  faces for 4 s (read at most 4,000 a second, the rest left to the kernel; faces given at most 120 a second; the
  server's CPU at most a third of a core in release), a port in use, a host not allowed, a port under 1024, a
  fifth receiver: error events naming the member, the session answering, the server up; the ports are closed
  with the session.
"""
import json
import os
import socket
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wsclient  # noqa: E402
from suite import check, finish, request, served  # noqa: E402

BIN, SRC = sys.argv[1:3]
SANITIZED = len(sys.argv) > 3 and sys.argv[3] == "sanitized"
LIVE = "/v1/rigs/facecap/live"


def udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def mesh(srv, body):
    body = dict(body, format="f32")
    return request(srv.url + "/v1/rigs/facecap/mesh", "POST", json.dumps(body).encode())[2]


def floats(b):
    return struct.unpack(f"<{len(b) // 4}f", b)


def session(srv):
    c = wsclient.Client(srv.port, LIVE)
    c.recv_json("ready")
    c.recv_frame()
    return c


def dump_frames(text):
    """oscdump's lines as frames: the Val values before each Apply."""
    frames, values = [], {}
    for line in text.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[1] == "/VMC/Ext/Blend/Apply":
            frames.append(values)
            values = {}
        elif len(parts) >= 5 and parts[1] == "/VMC/Ext/Blend/Val" and parts[2] == "sf":
            values[parts[3].strip('"')] = float(parts[4])
    return frames


def vmc_out(srv):
    port = udp_port()
    dump = subprocess.Popen(["oscdump", "-L", str(port)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    time.sleep(0.3)
    c = session(srv)
    c.send_text({"vmc": {"port": port}})
    e = c.recv_json("vmc")
    c.recv_frame()
    check(f"vmc: sending ({e})", e.get("state") == "sending" and e.get("targets") == 1 and e.get("port") == port)
    frames = 1
    for i, w in enumerate([0.2, 0.4, 0.6]):
        c.send_text({"weights": {"jawOpen": w, "eyeBlink_L": 1.0}, "id": i + 1})
        while c.recv_frame()[1] != i + 1:
            frames += 1
        frames += 1
        time.sleep(0.03)
    time.sleep(0.3)
    c.close()
    dump.terminate()
    got = dump_frames(dump.communicate(timeout=10)[0])
    last = got[-1] if got else {}
    check(f"vmc: oscdump got an Apply for each of the {frames} frames ({len(got)})", len(got) == frames)
    names = set(last)
    check(f"vmc: each frame carries ARKit's 52 and VRM 0.x's presets ({len(names)} values)",
          all(len(f) == 70 for f in got) and {"jawOpen", "eyeBlinkLeft", "tongueOut", "A", "Blink_L", "Joy"} <= names)
    check(f"vmc: the last frame's values are the weights set (jawOpen {last.get('jawOpen')}, eyeBlinkLeft "
          f"{last.get('eyeBlinkLeft')}, Blink_L {last.get('Blink_L')}, Joy {last.get('Joy')})",
          abs(last.get("jawOpen", 0) - 0.6) < 1e-6 and last.get("eyeBlinkLeft") == 1.0 and
          abs(last.get("Blink_L", 0) - 1.0) < 0.01 and last.get("Joy", 1) < 0.05 and last.get("mouthSmileLeft", 1) == 0)
    check("vmc: the first frame (the rest face) is all 0", got and all(v == 0 for v in got[0].values()))


def listen_port(c, member):
    c.send_text({member: {"port": 0}})
    e = c.recv_json(member)
    check(f"{member}: started on a port of its own ({e})", e.get("state") == "start" and e.get("port", 0) > 1023)
    return e.get("port", 0)


def vmc_in(srv):
    c = session(srv)
    port = listen_port(c, "listen_vmc")
    send = ["oscsend", "127.0.0.1", str(port)]
    subprocess.run(send + ["/VMC/Ext/Blend/Val", "sf", "jawOpen", "0.7"], check=True)
    subprocess.run(send + ["/VMC/Ext/Blend/Apply"], check=True)
    _, _, payload = c.recv_frame()
    check("listen_vmc: oscsend's jawOpen 0.7 and Apply give POST /mesh's face of jawOpen 0.7, byte for byte",
          payload == mesh(srv, {"weights": {"jawOpen": 0.7}}))
    # VMC's receivers keep a name's last value: jawOpen back to 0, then VRM 0.x's Joy.
    subprocess.run(send + ["/VMC/Ext/Blend/Val", "sf", "jawOpen", "0"], check=True)
    subprocess.run(send + ["/VMC/Ext/Blend/Val", "sf", "Joy", "1.0"], check=True)
    subprocess.run(send + ["/VMC/Ext/Blend/Val", "sf", "MyOwnClip", "1.0"], check=True)
    subprocess.run(send + ["/VMC/Ext/Blend/Apply"], check=True)
    unknown = c.recv_json("mocap")
    _, _, payload = c.recv_frame()
    want, rest = floats(mesh(srv, {"weights": {"happy": 1}, "vocabulary": "vrm"})), floats(mesh(srv, {}))
    got = floats(payload)
    n = len(want) // 2  # Positions, then normals.
    moved = max(abs(a - b) for a, b in zip(want[:n], rest[:n]))
    off = max(abs(a - b) for a, b in zip(want[:n], got[:n])) if len(got) == len(want) else 1e9
    check(f"listen_vmc: VRM 0.x's Joy smiles as {{\"vocabulary\": \"vrm\", \"happy\": 1}} does (off by {off:.2e}, "
          f"{off / moved:.1%} of its largest move {moved:.2e})", moved > 0 and off <= 0.02 * moved)
    check(f"listen_vmc: a name neither ARKit's nor a preset is said once ({unknown})", unknown.get("unknown") == ["MyOwnClip"])
    # A slider after the port's faces: the rig's own names, the port's weights (ARKit's) start over.
    c.send_text({"weights": {"mouthSmile_L": 0.5}, "id": 9})
    while True:
        _, ident, payload = c.recv_frame()
        if ident == 9:
            break
    check("a weights message after the port's faces starts over in the rig's own names (POST /mesh's mouthSmile_L 0.5 alone)",
          payload == mesh(srv, {"weights": {"mouthSmile_L": 0.5}}))
    c.send_text({"listen_vmc": False})
    end = c.recv_json("listen_vmc")
    check(f"listen_vmc false: ended with its counts ({end})", end.get("state") == "end" and end.get("packets") == 6)
    c.close()


def ifacialmocap_in(srv):
    c = session(srv)
    port = listen_port(c, "listen_ifacialmocap")
    u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    u.sendto(b"mouthSmile_R-0|jawOpen-50|eyeBlink_L-100|hapihapi-0|=head#-2.5,4.1,0.2,0.03,-0.08,-0.39|"
             b"rightEye#8.9,-4.7,-0.7|leftEye#8.8,-9.0,-1.4|", ("127.0.0.1", port))
    _, _, payload = c.recv_frame()
    check("listen_ifacialmocap: an iPhone's line moves it as arkit's jawOpen 0.5 and eyeBlink_L 1 would",
          payload == mesh(srv, {"weights": {"jawOpen": 0.5, "eyeBlink_L": 1}, "vocabulary": "arkit"}))
    c.close()
    time.sleep(0.5)
    again = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        again.bind(("127.0.0.1", port))
        check("the session's end closes its port", True)
    except OSError as e:
        check(f"the session's end closes its port ({e})", False)
    again.close()


def hostile(srv):
    c = session(srv)
    port = listen_port(c, "listen_vmc")
    u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    good = b"/VMC/Ext/Blend/Val\0\0,sf\0jawOpen\0" + struct.pack(">f", 0.3)
    for bad in [b"\xff" * 7, good[:-2], b"#bundle\0" + b"\0" * 8 + b"\x7f\xff\xff\xf0" + good, b"/a\0\0,q\0\0"]:
        u.sendto(bad, ("127.0.0.1", port))
    err = c.recv_json("error")
    check(f"garbage OSC: an error event at {err.get('pointer')} ({err.get('detail', '')[:80]})",
          err.get("type") == "malformed-datagram" and err.get("pointer") == "/listen_vmc")
    u.sendto(b"x" * 65000, ("127.0.0.1", port))
    # Two seconds of garbage and blends without their Apply, then two of whole faces (a blend and Apply a
    # datagram, as fast as Python sends): read at most 4,000 a second, given to the session at most 120.
    apply = b"/VMC/Ext/Blend/Apply\0\0\0\0,\0\0\0"
    bundle = b"#bundle\0" + struct.pack(">II", 0, 1) + struct.pack(">I", len(good)) + good + struct.pack(">I", len(apply)) + apply
    before = srv.cpu()
    t0 = time.time()
    sent = 0
    while time.time() - t0 < 4.0:
        first = time.time() - t0 < 2.0
        try:
            u.sendto((good if sent % 2 else os.urandom(64)) if first else bundle, ("127.0.0.1", port))
        except OSError:  # The kernel's buffer full: a flood is what it drops.
            pass
        sent += 1
    elapsed = time.time() - t0
    time.sleep(0.5)
    cpu = srv.cpu() - before
    c.send_text({"weights": {"jawOpen": 0.1}, "id": 77})
    while c.recv_frame()[1] != 77:
        pass
    check(f"after a flood of {sent} datagrams in {elapsed:.2f} s the session answers", True)
    c.send_text({"listen_vmc": False})
    end = c.recv_json("listen_vmc")
    cap = 4000 * (elapsed + 0.5) + 4000 + 10
    check(f"the flood: {end.get('packets')} datagrams read (at most {cap:.0f}: 4,000 a second and a second's burst)",
          end.get("packets", 1e9) <= cap)
    # The server's CPU for those seconds: the inlet's reading and 120 faces a second (a solve each) with their
    # frames. Under the sanitizers a figure only.
    check(f"the flood cost the server {cpu:.2f} CPU-seconds in {elapsed + 0.5:.1f} s (release: at most a third)",
          SANITIZED or cpu <= (elapsed + 0.5) / 3)
    # Refusals, each an error event naming its member; the session goes on.
    held = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    held.bind(("127.0.0.1", 0))
    for msg, code, pointer in [
        ({"listen_ifacialmocap": {"port": held.getsockname()[1]}}, "port-in-use", "/listen_ifacialmocap/port"),
        ({"listen_vmc": {"port": 80}}, None, "/listen_vmc/port"),
        ({"listen_vmc": {"port": 5000, "host": "x"}}, None, "/listen_vmc/host"),
        ({"vmc": {"port": 39539, "host": "10.1.2.3"}}, "host-not-allowed", "/vmc/host"),
        ({"vmc": {"port": 39539, "host": "example"}}, None, "/vmc/host"),
        ({"vmc": {"port": 70000}}, None, "/vmc/port"),
        ({"vmc": {"port": 39539}, "weights": {}}, None, "/vmc"),
    ]:
        c.send_text(msg)
        err = c.recv_json("error")
        check(f"{json.dumps(msg)}: error {err.get('type')} at {err.get('pointer')}",
              err.get("pointer") == pointer and (code is None or err.get("type") == code))
    held.close()
    for i in range(4):
        c.send_text({"vmc": {"port": 39600 + i}})
        c.recv_json("vmc")
    c.send_text({"vmc": {"port": 39700}})
    err = c.recv_json("error")
    check(f"a fifth VMC receiver: error {err.get('type')}", err.get("type") == "too-many-targets")
    c.send_text({"vmc": False})
    check("vmc false: stopped", c.recv_json("vmc").get("state") == "stopped")
    c.close()
    check("the server is up", srv.alive())


def main():
    with served(BIN, SRC, "k3y-mocap", "fs-mocap-") as (srv, _):
        vmc_out(srv)
        vmc_in(srv)
        ifacialmocap_in(srv)
        hostile(srv)
    finish()


if __name__ == "__main__":
    main()
