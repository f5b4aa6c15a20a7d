#!/usr/bin/env python3
"""The page's camera (issue 64): a video the service renders itself of FaceCap at known weights (held 2 s each:
rest, the jaw open, both eyes shut, a smile, the jaw and a smile), as the y4m Chromium's fake camera plays in a
loop, through the page's camera button in headless Chromium: MediaPipe's tracker (npm, served by the service)
finds the face, the live socket answers its weights. Each frame carries its number (squares in a corner, read by a
test hook of the page), so each answer is compared with the face of the frame it came from (a smoothing lag of up to
half a second allowed): jawOpen, eyeBlink and mouthSmile each within a mean error of 0.15 and a correlation
of 0.8 or more; and so do POST /capture's keys from the same landmarks (the page keeps what it sent). Stopped,
the recording saves as a motion.

  camera_test.py FACESPACE_BIN SOURCE_DIR NODE_MODULES
"""
import json
import os
import subprocess
import sys
import urllib.parse

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from suite import check, finish, request, served  # noqa: E402

BIN, SRC, MODULES = sys.argv[1:4]
FPS, HOLD = 30, 60  # Frames a second, frames a face is held.
FACES = [{}, {"jawOpen": 0.7}, {}, {"eyeBlink_L": 1, "eyeBlink_R": 1}, {}, {"mouthSmile_L": 0.8, "mouthSmile_R": 0.8},
         {}, {"jawOpen": 0.4, "mouthSmile_L": 0.5, "mouthSmile_R": 0.5}]
CHANNELS = {"jawOpen": ["jawOpen"], "eyeBlink": ["eyeBlink_L", "eyeBlink_R"], "mouthSmile": ["mouthSmile_L", "mouthSmile_R"]}


def channel(weights, names):
    return sum(weights.get(n, 0.0) for n in names) / len(names)


def tagged(plane, n):
    """A frame's Y, U, V bytes with its number in the top left: ten 16 x 16 squares, black 0 or white 1."""
    y = bytearray(plane)
    for b in range(10):
        v = 235 if (n >> b) & 1 else 16
        for row in range(16):
            y[row * 640 + 16 * b: row * 640 + 16 * b + 16] = bytes([v]) * 16
    return bytes(y)


def video(srv, tmp):
    """The y4m: each face rendered once (640 x 480), turned to 4:2:0 by ffmpeg, held HOLD frames, each frame's
    number drawn in its top left corner (the page's test hook reads it: the truth of the frame the tracker saw,
    whatever the fake camera's pace under load)."""
    planes = []
    for i, w in enumerate(FACES):
        q = "&".join(f"w.{k}={v}" for k, v in w.items())
        png = request(srv.url + f"/v1/rigs/facecap/render?width=640&height=480&{q}")[2]
        path = os.path.join(tmp, f"face{i}.png")
        open(path, "wb").write(png)
        planes.append(subprocess.run(["ffmpeg", "-loglevel", "error", "-i", path, "-pix_fmt", "yuv420p", "-f", "rawvideo", "-"],
                                     capture_output=True, check=True).stdout)
    out = os.path.join(tmp, "face.y4m")
    with open(out, "wb") as f:
        f.write(b"YUV4MPEG2 W640 H480 F30:1 Ip A1:1 C420jpeg\n")
        for k, p in enumerate(planes):
            for i in range(HOLD):
                f.write(b"FRAME\n" + tagged(p, k * HOLD + i))
    return out


def truth(t):
    """The faces' weights at video time t (seconds, looping)."""
    k = int(t * FPS) % (len(FACES) * HOLD) // HOLD
    return FACES[k]


def corr(a, b):
    n = len(a)
    ma, mb = sum(a) / n, sum(b) / n
    va = sum((x - ma) ** 2 for x in a)
    vb = sum((y - mb) ** 2 for y in b)
    return sum((x - ma) * (y - mb) for x, y in zip(a, b)) / ((va * vb) ** 0.5 or 1)


def follows(what, series):
    """Checks that `series` ([(frame number, weights)]) follows the video's faces at those frames, a lag of up to
    half a second allowed for the smoothing (the one that fits best)."""
    best = None
    for lag in range(0, 16):  # Frames.
        err = sum(abs(channel(w, names) - channel(truth((n - lag) / FPS), names)) for n, w in series for names in CHANNELS.values())
        if best is None or err < best[0]:
            best = (err, lag)
    lag = best[1] / FPS
    for name, names in CHANNELS.items():
        got = [channel(w, names) for _, w in series]
        want = [channel(truth(n / FPS - lag), names) for n, _ in series]
        mean = sum(abs(a - b) for a, b in zip(got, want)) / len(got)
        c = corr(got, want)
        check(f"{name}: {what} follow the video's (mean error {mean:.3f}, at most 0.15; correlation {c:.2f}, "
              f"at least 0.8; {len(got)} of them, {lag:.2f} s behind the frames they saw)", mean <= 0.15 and c >= 0.8)


def camera(srv, tmp):
    """The video, the page's camera on it, and what came back."""
    y4m = video(srv, tmp)
    check(f"the video: {len(FACES)} faces held {HOLD / FPS:.1f} s each, {os.path.getsize(y4m) >> 20} MB of y4m", os.path.getsize(y4m) > 0)
    out = os.path.join(tmp, "camera.json")
    run = subprocess.run(["node", os.path.join(SRC, "tests/integration/camera_test.mjs"), MODULES, srv.url, y4m, "40", out],
                         capture_output=True, text=True, timeout=300)
    r = json.load(open(out)) if os.path.exists(out) else {}
    log = r.get("log", [])
    check(f"the camera button runs MediaPipe's tracker on the camera: {r.get('found')} frames found a face, "
          f"{len(log)} weights events ({r.get('status')!r}; {run.stderr[-300:]})", len(log) >= 60 and r.get("on"))
    check(f"no page errors ({r.get('errors')})", not r.get("errors"))
    check("the camera button stops it", r.get("off"))
    if len(log) < 60:
        return
    tags = [e.get("tag") for e in log]
    check(f"each event knows the video frame its landmarks came from (frames {tags[0]} to {tags[-1]})", all(t is not None for t in tags))
    follows("the socket's weights", [(e["tag"], e["weights"]) for e in log if e.get("tag") is not None])
    motion = r.get("motion") or {}
    check(f"stopped, the recording saves as a motion ({r.get('motionName')}: {len(motion.get('keys', []))} keys)",
          len(motion.get("keys", [])) >= len(log) and r.get("motionName") == "facecap.camera.json")
    # The same landmarks offline: POST /capture (a key a frame), each key at its frame's time in the page.
    pts = r.get("points", [])
    fps = (len(pts) - 1) / ((pts[-1]["t"] - pts[0]["t"]) / 1000.0) if len(pts) > 1 else 30
    body = {"scheme": "mediapipe-478", "image": pts[0]["image"], "fps": round(fps, 3), "frames": [p["points"] for p in pts]}
    status, _, answer, _ = request(srv.url + "/v1/rigs/facecap/capture", "POST", json.dumps(body).encode(),
                                {"Content-Type": "application/json", "Authorization": "Bearer k3y-camera"})
    keys = json.loads(answer).get("keys", []) if status == 200 else []
    check(f"POST /capture of the same {len(pts)} frames: {status}, {len(keys)} keys", status == 200 and len(keys) == len(pts))
    if keys:
        follows("POST /capture's keys", [(p["tag"], k["weights"]) for p, k in zip(pts, keys) if p.get("tag") is not None])
    print(f"  screenshot: {out.replace('.json', '.png')}")


def main():
    with served(BIN, SRC, "k3y-camera", "fs-camera-") as (srv, tmp):
        camera(srv, tmp)
    finish()


if __name__ == "__main__":
    main()
