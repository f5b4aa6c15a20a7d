#!/usr/bin/env python3
"""Frames a real network carries (issue 64), against the real server on loopback.

  frames_test.py FACESPACE_BIN SOURCE_DIR NODE_MODULES

A slider dragged at 60 Hz for 2 s (jawOpen on FaceCap, あ on Uka, 0 to 1 and back) on three sessions side by side,
one a kind: {"frames": {"kind": "f32"}} (the default), "weights" and "delta". Measured: the bits a second each
kind costs, each frame awaited, so the figures are the bytes' and not the machine's: FaceCap's deltas at most
2 Mbit/s and weights at most 0.2, Uka's deltas at most 8. Checked: every delta frame, decoded by meshoptimizer's own JavaScript decoder (npm) and added up as a
browser adds it, within 1e-4 of the face's diagonal of the float32 frame of the same point; every weights frame's
weights the float32 bits of the ones asked; a keyframe first and again when asked; a bad kind an error event.
"""
import json
import os
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import wsclient  # noqa: E402
from suite import check, finish, request, served  # noqa: E402

BIN, SRC, MODULES = sys.argv[1:4]


def session(srv, rig, kind):
    """A session whose frames are of `kind`, and its first frame of that kind (the rest face)."""
    c = wsclient.Client(srv.port, f"/v1/rigs/{rig}/live")
    c.recv_json("ready")
    first = next_binary(c, 0)  # The rest face, as f32.
    if kind != "f32":
        c.send_text({"frames": {"kind": kind}})
        e = c.recv_json("frames")
        check(f"{rig} {kind}: the frames event ({e})", e.get("kind") == kind)
        first = next_binary(c, 0)  # The face again, in the new kind.
    return c, first


def next_binary(c, ident):
    """The binary message that shows `ident` (frames in between skipped)."""
    while True:
        op, payload = c.recv()
        if op == wsclient.BINARY and struct.unpack("<I", payload[8:12])[0] == ident:
            return payload


def drag(srv, rig, shape, tmp):
    kinds = ["f32", "weights", "delta"]
    cs, firsts = {}, {}
    for k in kinds:
        cs[k], firsts[k] = session(srv, rig, k)
    index = [s["name"] for s in json.loads(request(srv.url + f"/v1/rigs/{rig}")[2])["shapes"]].index(shape)
    sizes = {k: 0 for k in kinds}
    open(os.path.join(tmp, "rest.delta"), "wb").write(firsts["delta"])
    open(os.path.join(tmp, "rest.f32"), "wb").write(firsts["f32"])
    tags = [firsts["delta"][:4].decode()]
    listing, weights_ok = [{"tag": tags[0], "delta": "rest.delta", "f32": "rest.f32"}], True
    steps = 120
    for i in range(1, steps + 1):
        w = round(1 - abs(1 - 2 * i / steps), 4)  # 0 to 1 and back.
        t0 = time.time()
        for c in cs.values():
            c.send_text({"weights": {shape: w}, "id": i})
        got = {k: next_binary(c, i) for k, c in cs.items()}
        for k in kinds:
            sizes[k] += len(got[k])
        wf = got["weights"]
        n, nodes = struct.unpack("<II", wf[16:24])
        sent = struct.unpack(f"<{n}f", wf[24:24 + 4 * n])
        weights_ok = weights_ok and wf[:4] == b"wgts" and sent[index] == struct.unpack("<f", struct.pack("<f", w))[0] \
            and sum(1 for v in sent if v) == (1 if w else 0)
        tags.append(got["delta"][:4].decode())
        name = f"{rig}-{i}"
        open(os.path.join(tmp, name + ".delta"), "wb").write(got["delta"])
        open(os.path.join(tmp, name + ".f32"), "wb").write(got["f32"])
        listing.append({"tag": tags[-1], "delta": name + ".delta", "f32": name + ".f32"})
        time.sleep(max(0, 1 / 60 - (time.time() - t0)))
    # A keyframe when asked again.
    cs["delta"].send_text({"frames": {"kind": "delta"}})
    cs["delta"].recv_json("frames")
    op, again = cs["delta"].recv()
    check(f"{rig}: a keyframe first, deltas after, a keyframe when asked ({tags[0]}, {set(tags[1:])}, {again[:4]})",
          tags[0] == "dkey" and set(tags[1:]) == {"dlta"} and again[:4] == b"dkey")
    for c in cs.values():
        c.close()
    json.dump(listing, open(os.path.join(tmp, "frames.json"), "w"))
    out = subprocess.run(["node", os.path.join(SRC, "tests/integration/decode_frames.mjs"), MODULES, tmp],
                         capture_output=True, text=True, timeout=120)
    decoded = json.loads(out.stdout or "{}") if out.returncode == 0 else {}
    worst = decoded.get("worst", 1e9) / max(decoded.get("diagonal", 1), 1e-9)
    check(f"{rig}: {decoded.get('frames')} delta frames decoded by meshoptimizer's JavaScript decoder, the worst vertex "
          f"{worst:.2e} of the diagonal from the float32 frame's (at most 1e-4) {out.stderr[-300:]}",
          decoded.get("frames") == steps + 1 and worst <= 1e-4)
    check(f"{rig}: every weights frame carries the weight asked, float32 for float32, and no other", weights_ok)
    seconds = steps / 60
    mbit = {k: sizes[k] * 8 / seconds / 1e6 for k in kinds}
    print(f"  {rig}, {shape} dragged at 60 Hz: f32 {mbit['f32']:.2f} Mbit/s, delta {mbit['delta']:.3f}, "
          f"weights {mbit['weights']:.3f} ({sizes['f32'] // steps} / {sizes['delta'] // steps} / {sizes['weights'] // steps} bytes a frame)")
    return mbit


def main():
    with served(BIN, SRC, "k3y-frames", "fs-frames-") as (srv, tmp):
        face = drag(srv, "facecap", "jawOpen", tmp)
        check(f"FaceCap's jaw at 60 Hz: delta frames {face['delta']:.2f} Mbit/s (at most 2), weights {face['weights']:.3f} "
            f"(at most 0.2), against f32's {face['f32']:.1f}", face["delta"] <= 2 and face["weights"] <= 0.2)
        os.makedirs(os.path.join(tmp, "uka"), exist_ok=True)
        uka = drag(srv, "uka", "あ", os.path.join(tmp, "uka"))
        check(f"Uka's あ at 60 Hz: delta frames {uka['delta']:.2f} Mbit/s (at most 8), against f32's {uka['f32']:.1f}",
            uka["delta"] <= 8)
        c, _ = session(srv, "facecap", "f32")
        for msg, pointer in [({"frames": {"kind": "png"}}, "/frames/kind"), ({"frames": "delta"}, "/frames"),
                             ({"frames": {"kind": "delta", "x": 1}}, "/frames/x"), ({"frames": {"kind": "delta"}, "id": 3}, "/frames")]:
            c.send_text(msg)
            e = c.recv_json("error")
            check(f"{json.dumps(msg)}: error at {e.get('pointer')}", e.get("pointer") == pointer)
        c.close()
        check("the server is up", srv.alive())
    finish()


if __name__ == "__main__":
    main()
