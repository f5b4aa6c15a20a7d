#!/usr/bin/env python3
"""The hostile suite: the attacks of issue 33 against the real server on loopback.

  hostile_test.py FACESPACE_BIN SHARED_ASSETS SOURCE_DIR FIGURES_OUT [sanitized]

Each attack is answered with the right status, the server's RSS grows by at most 200 MB and is back near
idle after (not asserted under sanitizers, whose allocator keeps freed memory in quarantine), the server
stays alive, and a probe client is answered while 1,000 slow sockets are open. Speed bars (suite.bar, held by
tests/bench/bars.sh): each answer within 2 s (10 s under sanitizers), the probe's p99 within 1 s. The figures (attack, status, time, RSS before/after)
go to FIGURES_OUT as a Markdown table (tests/bench/README.md shows them).
"""
import json
import math
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from suite import Server as ServeProcess, bar, check, counts, probe_p99, request  # noqa: E402

BIN, SHARED, SRC, FIGURES = sys.argv[1:5]
SANITIZED = len(sys.argv) > 5 and sys.argv[5] in ("1", "ON", "on", "sanitized")
ANSWER_S = 10.0 if SANITIZED else 2.0
RSS_GROWTH_MB = 200
KEY = "k3y-hostile"

figures = []


def Server(tmp, *extra):
    return ServeProcess(BIN, tmp, *extra, store=os.path.join(tmp, "store"), jobs=os.path.join(tmp, "jobs"))


def raw(port, data, source="127.0.0.1", wait=5.0):
    """Sends bytes as they are; returns all that comes back until the server closes or `wait` passes."""
    s = socket.socket()
    s.bind((source, 0))
    s.settimeout(wait)
    s.connect(("127.0.0.1", port))
    s.sendall(data)
    out = b""
    end = time.time() + wait
    try:
        while time.time() < end:
            d = s.recv(65536)
            if not d:
                break
            out += d
    except (socket.timeout, ConnectionResetError):
        pass
    s.close()
    return out


def attack(srv, name, expect, fn):
    """Runs fn() -> (status, seconds, note); checks status, time, RSS growth and that the server lives."""
    before = srv.rss()
    status, seconds, note = fn()
    after_peak = srv.rss()
    time.sleep(0.3)
    after = srv.rss()
    alive = srv.alive()
    growth = after - before
    rss_ok = SANITIZED or growth <= RSS_GROWTH_MB
    figures.append((name, status, seconds, before, after))
    check(f"{name}: {status} (expected {expect}), RSS {before:.0f} -> {after:.0f} MB"
          f" (peak seen {after_peak:.0f}){', ' + note if note else ''}; server alive", status == expect and rss_ok and alive)
    bar(f"... in {seconds * 1000:.0f} ms (within {ANSWER_S:.0f} s)", seconds <= ANSWER_S)


def slow_sockets(port, count, sources):
    """Opens `count` sockets spread over `sources`, each sending the start of a request."""
    socks = []
    for i in range(count):
        s = socket.socket()
        s.bind((sources[i % len(sources)], 0))
        s.setblocking(False)
        try:
            s.connect(("127.0.0.1", port))
        except BlockingIOError:
            pass
        socks.append(s)
    time.sleep(0.3)
    for s in socks:
        try:
            s.send(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        except OSError:
            pass
    return socks


def drip(socks, stop):
    """One header byte a second on every socket, until `stop`."""
    while not stop.is_set():
        for s in socks:
            try:
                s.send(b"X")
            except OSError:
                pass
        stop.wait(1.0)


def closed_by_server(s):
    try:
        s.setblocking(True)
        s.settimeout(0.2)
        data = s.recv(4096)
        return data == b"" or data.startswith(b"HTTP/1.1 408") or data.startswith(b"HTTP/1.1 503")
    except socket.timeout:
        return False
    except OSError:
        return True


def status_of(data):
    try:
        return int(data.split(b" ", 2)[1])
    except (IndexError, ValueError):
        return 0


def glb_with_targets(n):
    """A glb of one triangle declaring n morph targets (all the same accessor)."""
    positions = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(positions)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(positions)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 0}] * n}]}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(positions)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(js), 0x4E4F534A) + js +
            struct.pack("<II", len(positions), 0x004E4942) + positions)


def vrm_uploads(srv, U, glb, tmp):
    """VRMs whose binds, springs or constraints point out of range or carry the wrong types: 422 naming the member,
    nothing stored. One with material colour and texture transform binds: stored, and its renders show them."""
    st, _, vrm, _ = request(U + "/v1/rigs/uka/mesh?format=vrm")
    check(f"GET uka/mesh?format=vrm: {st}, {len(vrm) >> 20} MB", st == 200 and vrm[:4] == b"glTF")
    src = os.path.join(tmp, "uka.vrm")
    open(src, "wb").write(vrm)
    edit = os.path.join(os.path.dirname(os.path.abspath(__file__)), "vrm_edit.py")
    subprocess.run([sys.executable, edit, "hostile", src, os.path.join(tmp, "vrm_hostile")], check=True)
    faults = json.load(open(os.path.join(tmp, "vrm_hostile", "faults.json")))
    for name, member in faults.items():
        data = open(os.path.join(tmp, "vrm_hostile", name + ".vrm"), "rb").read()
        st, sec, b, _ = request(U + "/v1/rigs/vrmbad", "PUT", data, glb)
        pointers = [e.get("pointer") for e in json.loads(b).get("errors", [])] if b.startswith(b"{") else []
        gone, _, _, _ = request(U + "/v1/rigs/vrmbad")
        check(f"PUT a VRM with {name}: {st} naming {member} in {sec * 1000:.0f} ms; nothing stored (GET {gone})",
              st == 422 and member in pointers and gone == 404 and srv.alive())
    subprocess.run([sys.executable, edit, "binds", src, os.path.join(tmp, "binds.vrm")], check=True)
    st, _, _, _ = request(U + "/v1/rigs/vrmbinds", "PUT", open(os.path.join(tmp, "binds.vrm"), "rb").read(), glb)
    renders = {e: request(U + f"/v1/rigs/vrmbinds/render?width=96&height=96{'&e.' + e + '=1' if e else ''}") for e in ("", "tint", "slide")}
    check(f"PUT a VRM whose expressions carry colour and texture binds: {st}; renders {[r[0] for r in renders.values()]}, tint and slide each "
          f"drawing other pixels than the neutral face", st == 201 and all(r[0] == 200 for r in renders.values())
          and renders["tint"][2] != renders[""][2] and renders["slide"][2] != renders[""][2])


def ball_obj(rows=24, cols=48, r=0.1):
    """A UV sphere as OBJ text: a mesh with no face on it."""
    v = ["v 0 %g 0" % r]
    for i in range(1, rows):
        t = math.pi * i / rows
        for j in range(cols):
            p = 2 * math.pi * j / cols
            v.append("v %.6f %.6f %.6f" % (r * math.sin(t) * math.cos(p), r * math.cos(t), r * math.sin(t) * math.sin(p)))
    v.append("v 0 %g 0" % -r)
    f, last = [], len(v)
    ring = lambda i, j: 2 + (i - 1) * cols + j % cols
    for j in range(cols):
        f.append("f 1 %d %d" % (ring(1, j + 1), ring(1, j)))
        f.append("f %d %d %d" % (last, ring(rows - 1, j), ring(rows - 1, j + 1)))
    for i in range(1, rows - 1):
        for j in range(cols):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            f.append("f %d %d %d" % (a, b, c))
            f.append("f %d %d %d" % (a, c, d))
    return ("\n".join(v + f) + "\n").encode()


def job_end(U, job, wait):
    """The job's JSON once it has ended (done, failed, cancelled, lost), or as it is after `wait` seconds; a job that
    cannot be read (the server gone) is {"state": "HTTP status"}."""
    deadline, j = time.time() + wait, {}
    while time.time() < deadline:
        st, _, b, _ = request(U + "/v1/jobs/" + job)
        j = json.loads(b) if st == 200 else {"state": f"HTTP {st}"}
        if j.get("state") in ("done", "failed", "cancelled", "lost") or st != 200:
            break
        time.sleep(0.2)
    return j


def derives(srv, U, auth, tmp):
    """POST /v1/rigs/{id}/derive: the key, bad requests named, a ball and a landmark off the mesh failing their job with the
    problem, nothing stored; a running derive deleted; a third at once refused 429."""
    post = lambda rig, body, h=auth: request(U + f"/v1/rigs/{rig}/derive", "POST", json.dumps(body).encode(), h)
    st, _, _, _ = post("facecap", {}, {})
    check(f"a derive without the key: {st}", st == 401)
    for body, pointer in (({"from": "nope"}, "/from"), ({"shapes": ["teeth"]}, "/shapes/0"), ({"as": "../etc"}, "/as"),
                          ({"landmarks": {"points": "x"}}, "/landmarks/points"), ({"frm": "facecap"}, "/frm")):
        st, _, b, _ = post("facecap", body)
        pointers = [e.get("pointer") for e in json.loads(b).get("errors", [])] if b.startswith(b"{") else []
        check(f"a derive with {json.dumps(body)}: {st} naming {pointers}", st == 422 and pointer in pointers)
    obj, ball = os.path.join(tmp, "ball.obj"), os.path.join(tmp, "ball.glb")
    open(obj, "wb").write(ball_obj())
    subprocess.run([BIN, "blend", obj, "-o", ball], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    st, _, _, _ = request(U + "/v1/rigs/ball", "PUT", open(ball, "rb").read(), {"Content-Type": "model/gltf-binary", **auth})
    check(f"a ball uploaded: {st}", st == 201)
    wait = 300 if SANITIZED else 60
    fails = {}
    for name, rig, body, pointer in (("a ball", "ball", {"as": "ball-arkit"}, "/landmarks"),
                                     ("a landmark off the mesh", "facecap", {"as": "facecap-off", "landmarks": {"points": [
                                         {"name": "nose_1", "vertex": 10**9}]}}, "/landmarks/points/0/vertex")):
        s2, _, b, _ = post(rig, body)
        j = job_end(U, json.loads(b)["id"], wait) if s2 == 202 else {}
        problem = j.get("problem", {})
        pointers = [e.get("pointer") for e in problem.get("errors", [])]
        gone, _, _, _ = request(U + "/v1/rigs/" + body["as"])
        fails[name] = (s2, j.get("state"), problem.get("status"), problem.get("type", "").rsplit(":", 1)[-1], pointers, gone)
        check(f"a derive onto {name}: {s2}, the job {j.get('state')} with {fails[name][2:5]}; nothing stored (GET {gone}); server alive",
              s2 == 202 and j.get("state") == "failed" and problem.get("status") == 422 and pointer in pointers and gone == 404
              and srv.alive())
    # Two at once are queued or running; a third is refused. The first, deleted as it runs, writes nothing.
    answers = [post("makehuman", {"as": f"facecap-d{i}"}) for i in range(3)]
    codes = [a[0] for a in answers]
    ids = [json.loads(a[2])["id"] for a in answers if a[0] == 202]
    deleted = [request(U + "/v1/jobs/" + i, "DELETE", headers=auth)[0] for i in ids]
    after = [request(U + "/v1/jobs/" + i)[0] for i in ids]
    time.sleep(3)
    stored = [request(U + f"/v1/rigs/facecap-d{i}")[0] for i in range(3)]
    check(f"three derives at once: {codes} (Retry-After {answers[2][3].get('Retry-After')}); deleted {deleted}, then GET {after}; "
          f"stored {stored}; server alive",
          codes == [202, 202, 429] and answers[2][3].get("Retry-After") and deleted == [204, 204] and after == [404, 404]
          and stored == [404, 404, 404] and srv.alive())


def retargets(srv, U):
    """Weights in another vocabulary: hostile names, vocabularies that are no id, a flood of names; each named, quick,
    and the server serving."""
    post = lambda body: request(U + "/v1/rigs/facecap/check", "POST", json.dumps(body).encode())
    for body, pointer in (({"vocabulary": "../../etc/passwd", "weights": {}}, "/vocabulary"),
                          ({"vocabulary": {"a": 1}, "weights": {}}, "/vocabulary"),
                          ({"vocabulary": "nobody-here", "weights": {"x": 1}}, "/vocabulary"),
                          ({"vocabulary": "mmd", "weights": [1, 0.5]}, "/weights/0"),
                          ({"vocabulary": "arkit", "weights": {"jawOpen": "x"}}, "/weights/jawOpen")):
        st, _, b, _ = post(body)
        pointers = [e.get("pointer") for e in json.loads(b).get("errors", [])] if b.startswith(b"{") else []
        check(f"retarget with {json.dumps(body, ensure_ascii=False)[:60]}: {st} naming {pointers[:2]}", st == 422 and pointer in pointers)
    flood = {"vocabulary": "arkit", "weights": {f"n{i}": 1 for i in range(60000)}}
    st, sec, b, _ = post(flood)
    errors = json.loads(b).get("errors", []) if b.startswith(b"{") else []
    check(f"60,000 unknown ARKit names: {st} in {sec * 1000:.0f} ms, {len(errors)} errors listed", st == 422 and len(errors) <= 20)
    bar(f"... within {ANSWER_S:.0f} s", sec <= ANSWER_S)
    st, _, b, _ = post({"vocabulary": "facecap", "weights": {n: 1 for n in ("jawOpen", "eyeBlink_L", "mouthSmile_R")}})
    check(f"... and the server serves a retarget after them: {st}", st == 200 and srv.alive())


def captures(srv, U):
    """A tracker's frames: too many, too short, not numbers, a face that is a ball; each named, quick, nothing kept
    wrong, and the server serving."""
    oval = [[320 + 100 * math.cos(i), 240 + 130 * math.sin(i), 0] for i in range(468)]
    post = lambda rig, body: request(U + f"/v1/rigs/{rig}/capture", "POST", json.dumps(body).encode())
    for name, body, pointer in (("3,601 frames", {"image": [640, 480], "frames": [[[0, 0, 0]]] * 3601}, "/frames"),
                                ("a frame of strings", {"image": [640, 480], "frames": [[["a", "b", "c"]] * 468]}, "/frames/0/0"),
                                ("an image of 0 pixels", {"image": [0, 480], "frames": [oval]}, "/image"),
                                ("the neutral past the frames", {"image": [640, 480], "frames": [oval], "neutral": 3}, "/neutral"),
                                ("an unknown member", {"image": [640, 480], "frames": [oval], "fsp": 30}, "/fsp")):
        st, sec, b, _ = post("facecap", body)
        pointers = [e.get("pointer") for e in json.loads(b).get("errors", [])] if b.startswith(b"{") else []
        check(f"capture with {name}: {st} naming {pointers[:2]} in {sec * 1000:.0f} ms", st == 422 and pointer in pointers)
    st, _, b, _ = post("ball", {"image": [640, 480], "frames": [oval]})
    detail = json.loads(b).get("detail", "") if b.startswith(b"{") else ""
    check(f"capture onto a ball: {st} ({detail[:70]}); server alive", st == 422 and "fit" in detail and srv.alive())
    st, _, _, _ = post("facecap", {"image": [640, 480], "frames": [oval]})
    check(f"... and a capture after them: {st}", st == 200)


def main():
    tmp = tempfile.mkdtemp(prefix="facespace-hostile-")
    os.makedirs(os.path.join(tmp, "store"))
    with open(os.path.join(tmp, "key"), "w") as f:
        f.write(KEY + "\n")
    auth = {"Authorization": "Bearer " + KEY}
    srv = Server(tmp, "--read-timeout", "3", "--max-batch", "65000", "--store-poll", "0.5")
    U = srv.url
    print(f"server on {U}, idle RSS {srv.idle:.0f} MB{' (sanitized: RSS not asserted)' if SANITIZED else ''}", flush=True)

    # ---- 1. a queued batch whose rig is uploaded again with identical bytes (use after free) ----
    cube = os.path.join(tmp, "uaf.glb")
    subprocess.run([BIN, "blend", os.path.join(SHARED, "real/AnimatedMorphCube/AnimatedMorphCube.gltf"), "--keep-targets", "-o", cube],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    cube_bytes = open(cube, "rb").read()
    glb = {"Content-Type": "model/gltf-binary", **auth}
    s1, _, _, _ = request(U + "/v1/rigs/uaf", "PUT", cube_bytes, glb)
    s2, _, b2, _ = request(U + "/v1/rigs/facecap/batch", "POST",
                           json.dumps({"sample": {"method": "uniform", "count": 3000}, "format": "png", "width": 64, "height": 64}).encode(), auth)
    busy = json.loads(b2).get("id", "") if s2 == 202 else ""
    s3, _, b3, _ = request(U + "/v1/rigs/uaf/batch", "POST", json.dumps({"sample": {"method": "uniform", "count": 200}, "format": "json"}).encode(), auth)
    queued = json.loads(b3).get("id", "") if s3 == 202 else ""
    s4, _, _, _ = request(U + "/v1/rigs/uaf", "PUT", cube_bytes, glb)
    s5, _, _, _ = request(U + "/v1/jobs/" + busy, "DELETE", headers=auth)
    state = job_end(U, queued, 120 if SANITIZED else 30).get("state", "")
    figures.append(("queued batch, its rig uploaded again (same bytes), the running job deleted", f"job {state}", 0, srv.idle, srv.rss()))
    check(f"a queued batch whose rig is uploaded again with the same bytes while another job runs: the server lives and the job is "
          f"{state} (PUT {s1}, batches {s2}/{s3}, PUT again {s4}, DELETE {s5})",
          (s1, s2, s3, s4, s5) == (201, 202, 202, 200, 204) and state == "done" and srv.alive())
    if srv.proc.poll() is not None:  # It died: what it said last, and no further attack.
        srv.log.flush()
        print("".join(open(srv.log.name).readlines()[-5:]))
        print(f"{counts['passed']} passed, {counts['failed'] + 1} failed")
        return 1

    # ---- 2. error lists without a cap ----
    check_url = U + "/v1/rigs/facecap/check"

    def post(url, body):
        def run():
            st, sec, b, _ = request(url, "POST", body)
            return st, sec, f"{len(b)} bytes answered"
        return run

    zeros6 = ('{"weights":[' + ",".join(["0"] * 10**6) + "]}").encode()
    attack(srv, "/check with 10^6 zeros (2 MB)", 413, post(check_url, zeros6))
    del zeros6
    zeros7 = ('{"weights":[' + ",".join(["0"] * 10**7) + "]}").encode()
    attack(srv, "/check with 10^7 zeros (20 MB)", 413, post(check_url, zeros7))
    del zeros7
    names6 = ('{"weights":{' + ",".join(f'"n{i}":0' for i in range(10**6)) + "}}").encode()
    attack(srv, "/check with 10^6 unknown names (12 MB)", 413, post(check_url, names6))
    del names6
    names = ('{"weights":{' + ",".join(f'"n{i}":0' for i in range(90000)) + "}}").encode()
    st, sec, b, _ = request(check_url, "POST", names)
    doc = json.loads(b) if st == 422 else {}
    figures.append(("/check with 90,000 unknown names (under the value cap)", st, sec, srv.rss(), srv.rss()))
    check(f"/check with 90,000 unknown names: 422 listing {len(doc.get('errors', []))} errors of "
          f"errors_total {doc.get('errors_total')} ({len(b)} bytes)",
          st == 422 and len(doc.get("errors", [])) == 20 and doc.get("errors_total") == 90000 and len(b) < 20000)
    bar(f"... in {sec * 1000:.0f} ms (within {ANSWER_S:.0f} s)", sec <= ANSWER_S)
    dense = ('{"weights":[' + ",".join(["0"] * 60000) + "]}").encode()
    st, sec, b, _ = request(check_url, "POST", dense)
    check(f"/check with 60,000 weights for 52 shapes: 422 with one error ({len(b)} bytes)",
          st == 422 and len(json.loads(b).get("errors", [])) == 1)
    bar(f"... in {sec * 1000:.0f} ms (within {ANSWER_S:.0f} s)", sec <= ANSWER_S)

    # ---- 3. quadratic parsing ----
    objs = ('{"weights":{},"x":[' + ",".join(["{}"] * 100000) + "]}").encode()
    attack(srv, "/mesh with 100,000 empty objects (300 KB)", 413, post(U + "/v1/rigs/facecap/mesh", objs))
    objs = ('{"weights":{},"x":[' + ",".join(["{}"] * 90000) + "]}").encode()
    attack(srv, "/mesh with 90,000 empty objects (under the value cap)", 422, post(U + "/v1/rigs/facecap/mesh", objs))
    keys = ('{"keys":[' + ",".join('{"time":%d}' % i for i in range(10**6)) + '],"times":[0.5]}').encode()
    attack(srv, f"sequence/sample with 10^6 keys ({len(keys) >> 20} MB)", 413, post(U + "/v1/rigs/facecap/sequence/sample", keys))
    del keys

    # ---- 4. slow clients ----
    stop = threading.Event()
    before = srv.rss()
    socks = slow_sockets(srv.port, 320, ["127.0.0.2", "127.0.0.3"])
    dripper = threading.Thread(target=drip, args=(socks, stop))
    dripper.start()
    time.sleep(1.0)
    p99, p50 = probe_p99(U, 20)
    time.sleep(4.5)  # --read-timeout 3: every slow request is cut off by now.
    cut = sum(closed_by_server(s) for s in socks)
    stop.set()
    dripper.join()
    for s in socks:
        s.close()
    figures.append(("slowloris: 320 sockets, a header byte a second", f"{cut} cut off", p99, before, srv.rss()))
    check(f"slowloris, 320 sockets sending a header byte a second: every probe answered, {cut}/320 cut off after --read-timeout (3 s)",
          p99 < 99 and cut == 320 and srv.alive())
    bar(f"... the probes' p99 {p99 * 1000:.0f} ms (median {p50 * 1000:.0f}; within 1 s)", p99 <= 1.0)

    before = srv.rss()
    socks = slow_sockets(srv.port, 1000, ["127.0.0.4", "127.0.0.5", "127.0.0.6", "127.0.0.7"])
    stop = threading.Event()
    dripper = threading.Thread(target=drip, args=(socks, stop))
    dripper.start()
    time.sleep(0.5)
    p99, p50 = probe_p99(U, 40)
    with open(f"/proc/{srv.proc.pid}/status") as f:
        threads = next(int(l.split()[1]) for l in f if l.startswith("Threads:"))
    stop.set()
    dripper.join()
    for s in socks:
        s.close()
    figures.append(("1,000 slow sockets open (4 addresses)", "probe 200", p99, before, srv.rss()))
    check(f"1,000 slow sockets open from 4 addresses: every probe answered; the server has {threads} threads", p99 < 99 and srv.alive())
    bar(f"... the probes' p99 {p99 * 1000:.0f} ms (of 40, median {p50 * 1000:.0f}; within 1 s)", p99 <= 1.0)

    socks = slow_sockets(srv.port, 300, ["127.0.0.8"])
    time.sleep(0.5)
    refused = sum(status_of(s.recv(200)) == 503 if select_readable(s) else 0 for s in socks)
    for s in socks:
        s.close()
    figures.append(("300 connections from one address", f"{refused} x 503", 0, srv.rss(), srv.rss()))
    check(f"300 connections from one address: {refused} answered 503 with Retry-After (256 a client)", refused == 44 and srv.alive())

    # ---- 5. renders that would take gigabytes ----
    def get(url):
        def run():
            st, sec, b, _ = request(url)
            return st, sec, f"{len(b)} bytes"
        return run

    sheet = json.dumps({"cells": [{"weights": {"jawOpen": i / 64}} for i in range(64)], "width": 2048, "height": 2048}).encode()
    attack(srv, "sheet of 64 cells at 2048²", 413, post(U + "/v1/rigs/facecap/sheet", sheet))
    attack(srv, "render 2048² with supersample 4", 413, get(U + "/v1/rigs/facecap/render?width=2048&height=2048&supersample=4"))
    before = srv.rss()
    st, sec, b, _ = request(U + "/v1/rigs/facecap/render?width=2048&height=2048&w.jawOpen=0.3")
    time.sleep(0.5)
    after = srv.rss()
    figures.append(("render 2048² (allowed: about 300 MB of working memory)", st, sec, before, after))
    check(f"a 2048² render (within the budget): {st} in {sec * 1000:.0f} ms, RSS {before:.0f} -> {after:.0f} MB: its memory given back",
          st == 200 and (SANITIZED or after - before <= RSS_GROWTH_MB) and srv.alive())

    # ---- 6. smaller ones ----
    r = raw(srv.port, b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\nGET /readyz HTTP/1.1\r\nHost: x\r\n\r\n"
                      b"GET /v1/rigs/nope HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    answers = [status_of(b"HTTP/1.1" + part) for part in r.split(b"HTTP/1.1")[1:]]
    check(f"three pipelined requests in one packet: answered in order {answers}", answers == [200, 200, 404])
    r = raw(srv.port, b"POST /v1/rigs/facecap/check HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n"
                      b"5;x=1\r\n{\"wei\r\ne\r\nghts\":{\"0\":1}}\r\n0\r\nX-Trailer: 1\r\n\r\n"
                      b"GET /readyz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
    answers = [status_of(b"HTTP/1.1" + part) for part in r.split(b"HTTP/1.1")[1:]]
    check(f"a chunked body with a chunk extension and a trailer, a request pipelined behind it: {answers}, the weights read",
          answers == [200, 200] and b'"browInnerUp":1' in r)

    def framing(name, data, expect):
        def run():
            t = time.time()
            out = raw(srv.port, data, wait=ANSWER_S + 1)
            return status_of(out), time.time() - t, ""
        attack(srv, name, expect, run)

    head = b"POST /v1/rigs/facecap/check HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
    framing("a chunk without its trailing CRLF", head + b"Transfer-Encoding: chunked\r\n\r\n2\r\n{}XX0\r\n\r\n", 400)
    framing("Transfer-Encoding and Content-Length together", head + b"Transfer-Encoding: chunked\r\nContent-Length: 2\r\n\r\n{}", 400)
    framing("Content-Length: abc", head + b"Content-Length: abc\r\n\r\n{}", 400)
    framing("Content-Length: -5", head + b"Content-Length: -5\r\n\r\n{}", 400)
    framing("a path with %u0066", b"GET /v1/rigs/%u0066acecap HTTP/1.1\r\nHost: x\r\n\r\n", 400)
    st, _, b, _ = request(U + "/v1/rigs/facecap/mesh?w.jawOpen=0x10&format=json")
    check(f"w.jawOpen=0x10 is not a number: {st} naming the parameter", st == 422 and b"w.jawOpen" in b)

    big = glb_with_targets(100000)
    attack(srv, f"upload of a glb declaring 100,000 morph targets ({len(big) >> 20} MB)", 413,
           lambda: (lambda st, sec, b, h: (st, sec, b[:0].decode() + ("names --max-shapes" if b"--max-shapes" in b else "")))(
               *request(U + "/v1/rigs/manytargets", "PUT", big, glb)))

    vrm_uploads(srv, U, glb, tmp)
    derives(srv, U, auth, tmp)
    retargets(srv, U)
    captures(srv, U)

    st, sec, b, _ = request(U + "/v1/rigs/facecap/batch", "POST",
                            json.dumps({"sample": {"method": "uniform", "count": 65000}, "format": "exr", "width": 2048, "height": 2048}).encode(), auth)
    figures.append(("batch of 65,000 2048² EXR variants (about 2 TB)", st, sec, srv.rss(), srv.rss()))
    check(f"a batch that cannot fit on the disk (65,000 2048² EXR): {st} "
          f"({json.loads(b).get('detail', '')[:100] if b.startswith(b'{') else ''})", st == 507)
    bar(f"... in {sec * 1000:.0f} ms (within {ANSWER_S:.0f} s)", sec <= ANSWER_S)

    store = os.path.join(tmp, "store")
    old_tmp, new_tmp = os.path.join(store, ".gone.1.0.tmp"), os.path.join(store, ".kept.1.1.tmp")
    for p in (old_tmp, new_tmp):
        with open(p, "w") as f:
            f.write("half an upload")
    old = time.time() - 1200
    os.utime(old_tmp, (old, old))
    time.sleep(1.5)
    check("an upload's temporary left 20 minutes ago by a killed instance is removed by the store poll; a fresh one is kept",
          not os.path.exists(old_tmp) and os.path.exists(new_tmp))
    os.remove(new_tmp)

    idle_after = srv.rss()
    check(f"after every attack: RSS {idle_after:.0f} MB against {srv.idle:.0f} MB idle at start (at most +{RSS_GROWTH_MB} MB)",
          SANITIZED or idle_after - srv.idle <= RSS_GROWTH_MB)
    rc = srv.stop()
    check(f"the server stops cleanly on SIGTERM (exit {rc})", rc == 0)

    with open(FIGURES, "w") as f:
        f.write("| attack | answer | time | RSS before → after |\n|---|---|---|---|\n")
        for name, status, sec, before, after in figures:
            f.write(f"| {name} | {status} | {sec * 1000:.0f} ms | {before:.0f} → {after:.0f} MB |\n")
    print(f"figures: {FIGURES}")
    print(f"{counts['passed']} passed, {counts['failed']} failed")
    return 1 if counts["failed"] else 0


def select_readable(s, wait=0.5):
    import select
    s.setblocking(True)
    r, _, _ = select.select([s], [], [], wait)
    return bool(r)


if __name__ == "__main__":
    sys.exit(main())
