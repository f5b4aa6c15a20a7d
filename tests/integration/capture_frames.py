"""Frames of MediaPipe landmarks for the capture route's tests, as a tracker would give them of a face:
MediaPipe's canonical face (vertex i is landmark i) put in a 640x480 image's pixels, at rest and then with
its jaw turned open about a pivot below the ears (the lower lip and chin turning, the rest still).

    python3 capture_frames.py canonical_face_model.obj OUT.json [--rest N] [--open N] [--degrees D]
"""
import json
import math
import sys


def frames(obj, rest=5, opened=15, degrees=12.0):
    pts = [list(map(float, line.split()[1:4])) for line in open(obj) if line.startswith("v ")]
    lips = (pts[13][1] + pts[14][1]) / 2  # MediaPipe's inner lips: 13 upper, 14 lower.

    def frame(angle):
        out = []
        for x, y, z in pts:
            share = max(0.0, min(1.0, (lips - y) + 0.5)) if y < lips + 0.5 else 0.0
            a = math.radians(angle) * share
            dy, dz = y + 1.0, z + 2.0  # The pivot: 1 cm below the nose, 2 cm behind the face's origin.
            ry, rz = -1.0 + dy * math.cos(a) - dz * math.sin(a), -2.0 + dy * math.sin(a) + dz * math.cos(a)
            out.append([round(320 + 20 * x, 3), round(240 - 20 * ry, 3), round(-20 * rz, 3)])
        return out

    return [frame(0)] * rest + [frame(degrees)] * opened


if __name__ == "__main__":
    args = sys.argv[1:]
    get = lambda flag, d: float(args[args.index(flag) + 1]) if flag in args else d
    body = {"scheme": "mediapipe-468", "image": [640, 480], "fps": 30,
            "frames": frames(args[0], int(get("--rest", 5)), int(get("--open", 15)), get("--degrees", 12.0))}
    json.dump(body, open(args[1], "w"))
