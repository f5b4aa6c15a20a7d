"""Issue 52's dataset from the outside: `facespace batch --labels ... --archive tar` as a person runs it, and the
batch route with the same members. WebDataset shards read with Python's tarfile, each sample whole (its
KEY.png, KEY.depth.exr, KEY.normals.exr, KEY.seg.png, KEY.json, the sizes its manifest line says); the
same seed gives the same bytes; shards run apart and merged give the one-process dataset; a kill -9 mid-run
leaves only whole shards under their names and a rerun finishes the same bytes; a file size limit (a full
disk) fails the run cleanly, publishes nothing half-written, and a rerun resumes; bad members are refused
naming the valid ones; background pictures from a folder go behind each sample (the CLI's alone).
usage: dataset_test.py FACESPACE_BINARY SOURCE_DIR"""
import filecmp
import io
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tarfile
import tempfile
import time
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from suite import Server, check, counts, request  # noqa: E402

binary, src = sys.argv[1], sys.argv[2]
facecap = os.path.join(src, "assets/facecap/facecap.glb")
tmp = tempfile.mkdtemp(prefix="fs-dataset-")
RANDOM = '{"camera": {"yaw": [-30, 30], "pitch": [-10, 10]}, "light": {"yaw": [-60, 60]}, "background": "random"}'
SUFFIXES = ["png", "depth.exr", "normals.exr", "seg.png", "json"]


def batch_args(out, count, *extra):
    """The test's labelled FaceCap batch into `out` (96², tar shards of 16, 2 jobs), with `extra` flags."""
    return [binary, "batch", facecap, "--sample", "uniform", "--count", str(count), "--seed", "5", "--active", "4",
            "--labels", "depth,normals,segmentation,landmarks", "--width", "96", "--height", "96", "--randomize", RANDOM,
            "--archive", "tar", "--shard-samples", "16", "--jobs", "2", "-o", out, *extra]


def batch(out, count, *extra, limit=None):
    """The CLI's exit code and stderr; `limit`: a file size limit in bytes (SIGXFSZ ignored, so writes fail EFBIG)."""
    def child():
        if limit:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    p = subprocess.run(batch_args(out, count, "-q", *extra), capture_output=True, text=True, preexec_fn=child)
    return p.returncode, p.stderr


def shards(folder):
    return sorted(f for f in os.listdir(folder) if f.startswith("shard-") and f.endswith(".tar"))


def whole_samples(folder):
    """Every named shard read with tarfile: {key: {suffix: bytes}}, and the problems found."""
    samples, problems = {}, []
    for name in shards(folder):
        try:
            with tarfile.open(os.path.join(folder, name)) as t:
                for m in t.getmembers():
                    key, suffix = m.name.split(".", 1)
                    samples.setdefault(key, {})[suffix] = t.extractfile(m).read()
        except (tarfile.TarError, OSError, ValueError) as e:
            problems.append(f"{name}: {e}")
    for key, files in samples.items():
        if sorted(files) != sorted(SUFFIXES):
            problems.append(f"{key}: has {sorted(files)}")
        elif not files["png"].startswith(b"\x89PNG") or not files["depth.exr"].startswith(b"\x76\x2f\x31\x01"):
            problems.append(f"{key}: a file is not what its name says")
    return samples, problems


def manifest(folder):
    with open(os.path.join(folder, "manifest.jsonl")) as f:
        return [json.loads(line) for line in f if line.strip()]


def differences(a, b):
    """The files of dataset `b` that are not byte for byte those of `a` (its shards and manifest), each with the
    first sample file that differs inside it: [] when they are the same dataset."""
    if shards(a) != shards(b):
        return [f"shards {shards(a)} against {shards(b)}"]
    found = []
    for n in shards(a) + ["manifest.jsonl"]:
        pa, pb = os.path.join(a, n), os.path.join(b, n)
        if not os.path.exists(pb) or not filecmp.cmp(pa, pb, shallow=False):
            found.append(n)
            if n.endswith(".tar") and os.path.exists(pb):
                with tarfile.open(pa) as ta, tarfile.open(pb) as tb:
                    names = ta.getnames()
                    found += [m for m in names if m in tb.getnames() and ta.extractfile(m).read() != tb.extractfile(m).read()][:1]
    return found


def same_dataset(a, b):
    """True when `b` is `a` byte for byte; else it says which files differ (the check's line follows)."""
    found = differences(a, b)
    if found:
        print(f"     {os.path.basename(b)} differs from {os.path.basename(a)}: {found}")
    return not found


# One run, read back.
ref = os.path.join(tmp, "ref")
rc, err = batch(ref, 40)
check(f"batch --labels ... --archive tar: 40 samples in {len(shards(ref))} shards (rc {rc}) {err.strip()[-200:]}", rc == 0 and shards(ref) == [
    "shard-000000.tar", "shard-000001.tar", "shard-000002.tar"])
samples, problems = whole_samples(ref)
check(f"tarfile reads every shard; each of the 40 samples has its 5 files, as WebDataset groups them by key {problems[:3]}",
      len(samples) == 40 and not problems)
lines = manifest(ref)
sizes_ok = all(samples[l["id"]][f["file"].split(".", 1)[1]].__len__() == f["bytes"] for l in lines for f in l["files"])
check("manifest.jsonl: a line per sample, its shard and offset, every file's size as in the shard", len(lines) == 40 and sizes_ok and
      all(l["shard"] == f"shard-{l['index'] // 16:06d}.tar" for l in lines))
j = json.loads(samples["v000007"]["json"])
check("KEY.json: K, world_to_camera 4 x 4, the depth's meaning, the segments' legend, 68 landmarks with xy, xyz, visible, the point",
      len(j["camera"]["K"]) == 3 and len(j["camera"]["world_to_camera"]) == 4 and j["depth"] == "distance along the ray, metres" and
      j["segmentation"]["0"] == "background" and "skin" in j["segmentation"].values() and len(j["landmarks"]) == 68 and
      set(j["landmarks"][0]) == {"name", "xy", "xyz", "visible"} and "weights" in j and "render" in j)

# The same seed, the same bytes.
again = os.path.join(tmp, "again")
rc, _ = batch(again, 40)
check("the same command again: byte-identical shards and manifest", rc == 0 and same_dataset(ref, again))

# Makers: a process a job (the default from 1,000 renders; the closing line says how many) make the threads' bytes.
p = subprocess.run(batch_args(os.path.join(tmp, "said"), 40, "--workers", "processes"), capture_output=True, text=True)
check(f"--workers processes: the closing line names the 2 maker processes ({[l for l in p.stderr.splitlines() if 'variants/s' in l]})",
      p.returncode == 0 and "2 maker processes" in p.stderr)
check("the maker processes' samples: the same bytes as the threads'", same_dataset(ref, os.path.join(tmp, "said")))
rc, err = batch(os.path.join(tmp, "bad0"), 2, "--workers", "fibers")
check(f"--workers fibers: a usage error naming processes and threads ({err.strip()[:120]})", rc == 2 and "processes" in err and "threads" in err)

# The same seed, the same bytes, at 256² over 150 samples: igzip at level 1 wrote a few label files in some hundred
# samples in other (valid) bytes from run to run; the 96² run above was too small to show it.
big = [os.path.join(tmp, f"big{i}") for i in range(2)]
rcs = [batch(b, 150, "--width", "256", "--height", "256", "--shard-samples", "150", "--workers", w)[0] for b, w in zip(big, ["processes", "threads"])]
check("150 samples at 256², by makers and by threads: byte-identical shards and manifest", rcs == [0, 0] and same_dataset(big[0], big[1]))
for b in big:
    shutil.rmtree(b, ignore_errors=True)


def makers_of(pid):
    """The pids of `pid`'s children (its maker processes)."""
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            return [int(x) for x in f.read().split()]
    except OSError:
        return []


def alive(pids):
    return [p for p in pids if os.path.exists(f"/proc/{p}") and not open(f"/proc/{p}/stat").read().split(") ")[1].startswith("Z")]


def start_and_wait(out, *extra):
    """A 40-sample run started, returned once its first shard is published and its makers are known."""
    proc = subprocess.Popen(batch_args(out, 40, "--workers", "processes", "-q", *extra), stderr=subprocess.PIPE, text=True)
    deadline, makers = time.time() + 60, []
    while time.time() < deadline and not os.path.exists(os.path.join(out, "shard-000000.tar")):
        makers = makers_of(proc.pid) or makers
        time.sleep(0.002)
    return proc, makers_of(proc.pid) or makers


# A maker killed mid-run: the run fails saying so, what is named is whole, a rerun finishes the same bytes.
lost = os.path.join(tmp, "lost")
proc, makers = start_and_wait(lost)
if makers:
    os.kill(makers[0], signal.SIGKILL)
_, err = proc.communicate(timeout=60)
samples, problems = whole_samples(lost)
check(f"kill -9 of one of the {len(makers)} makers: exit 1 naming the lost maker, every named sample whole ({err.strip()[-160:]})",
      len(makers) == 2 and proc.returncode == 1 and "sample maker process" in err and "signal 9" in err and not problems and
      not alive(makers))
rc, _ = batch(lost, 40)
check("the rerun resumes and ends byte-identical to an uninterrupted run", rc == 0 and same_dataset(ref, lost))

# SIGTERM: the run stops resumably (exit 130) and its makers end with it; a rerun finishes the same bytes.
termed = os.path.join(tmp, "termed")
proc, makers = start_and_wait(termed)
proc.send_signal(signal.SIGTERM)
_, err = proc.communicate(timeout=60)
time.sleep(0.2)
check(f"SIGTERM mid-run: exit 130 and no maker left ({err.strip()[-120:]})", len(makers) == 2 and proc.returncode == 130 and not alive(makers))
rc, _ = batch(termed, 40)
check("the rerun finishes byte-identical", rc == 0 and same_dataset(ref, termed))

# Shards of a job array, merged.
split = os.path.join(tmp, "split")
rc1, _ = batch(split, 40, "--shard", "1/2")
rc2, _ = batch(split, 40, "--shard", "2/2")
p = subprocess.run([binary, "batch", "merge", split], capture_output=True, text=True)
check(f"--shard 1/2 and 2/2 (whole tar shards each), then batch merge: the one-process dataset byte for byte (rc {rc1} {rc2} {p.returncode})",
      rc1 == 0 and rc2 == 0 and p.returncode == 0 and same_dataset(ref, split))

# kill -9 mid-run (maker processes): what is named is whole, no maker is left; a rerun finishes the same bytes.
killed = os.path.join(tmp, "killed")
proc, makers = start_and_wait(killed)
proc.send_signal(signal.SIGKILL)
proc.wait()
time.sleep(0.2)
check(f"kill -9 of the batch takes its {len(makers)} maker processes with it", len(makers) == 2 and not alive(makers))
named = shards(killed)
samples, problems = whole_samples(killed)
check(f"kill -9 mid-run: {len(named)} shard(s) under their names, every sample in them whole ({len(samples)} samples) {problems[:3]}",
      0 < len(named) < 3 and not problems and len(samples) == 16 * len(named))
rc, err = batch(killed, 40)
check(f"the rerun resumes after the published samples and ends byte-identical to an uninterrupted run (rc {rc}) {err.strip()[-160:] if rc else ''}",
      rc == 0 and same_dataset(ref, killed))

# A full disk (a file size limit): a clean failure, nothing half-written under a name, then a resume.
full = os.path.join(tmp, "full")
rc, err = batch(full, 40, limit=300_000)
samples, problems = whole_samples(full)
check(f"a file size limit mid-shard: exit 1 saying the disk is full, every named shard whole ({len(shards(full))} named) ({err.strip()[-160:]})",
      rc == 1 and ("File too large" in err or "space" in err) and not problems)
rc, _ = batch(full, 40)
check("the rerun without the limit resumes and ends byte-identical", rc == 0 and same_dataset(ref, full))

# Bad members, as the CLI says them.
rc, err = batch(os.path.join(tmp, "bad1"), 2, "--labels", "depth,albedo")
check(f"--labels depth,albedo: a usage error naming the labels ({err.strip()[:160]})", rc == 2 and "albedo" in err and "segmentation" in err)
rc, err = batch(os.path.join(tmp, "bad2"), 2, "--archive", "zip")
check(f"--archive zip: a usage error naming the archives ({err.strip()[:160]})", rc == 2 and "tar" in err and "folder" in err)
p = subprocess.run([binary, "batch", os.path.join(src, "assets/makehuman/makehuman.glb"), "--sample", "uniform", "--count", "2",
                    "--labels", "landmarks", "-q", "-o", os.path.join(tmp, "bad3")], capture_output=True, text=True)
check(f"landmarks of a rig without any: refused, saying so ({p.stderr.strip()[:160]})", p.returncode == 2 and "no landmarks" in p.stderr)


def write_png(path, w, h, rgb):
    """An 8-bit RGB PNG of rgb(x, y)."""
    import struct
    import zlib
    rows = b"".join(b"\0" + b"".join(bytes(rgb(x, y)) for x in range(w)) for y in range(h))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(rows)) +
                chunk(b"IEND", b""))


def read_png(data):
    """(width, height, channels, rows of bytes) of an 8-bit PNG (any filter)."""
    import struct
    import zlib
    w, h, depth, kind = struct.unpack(">IIBB", data[16:26])
    channels = {0: 1, 2: 3, 6: 4}[kind]
    idat, at = b"", 8
    while at < len(data):
        n, t = struct.unpack(">I4s", data[at:at + 8])
        if t == b"IDAT":
            idat += data[at + 8:at + 8 + n]
        at += 12 + n
    raw, stride, rows, prev = zlib.decompress(idat), w * channels, [], bytearray(w * channels)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b, c = prev[i], prev[i - channels] if i >= channels else 0
            pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
            pred = [0, a, b, (a + b) // 2, a if pa <= pb and pa <= pc else b if pb <= pc else c][f]
            line[i] = (line[i] + pred) & 255
        rows.append(line)
        prev = line
    return w, h, channels, rows


# Background pictures from a folder: one behind each sample, drawn from its stream, named in KEY.json.
pictures = os.path.join(tmp, "backgrounds")
os.makedirs(pictures)
write_png(os.path.join(pictures, "checker.png"), 48, 96, lambda x, y: (230, 200, 40) if (x // 8 + y // 8) % 2 else (30, 90, 160))
write_png(os.path.join(pictures, "plain.png"), 40, 30, lambda x, y: (200, 30, 30))
with open(os.path.join(pictures, "readme.txt"), "w") as f:
    f.write("not a picture")
BG = '{"camera": {"yaw": [-30, 30]}, "background": {"images": "%s"}}' % pictures
bg = os.path.join(tmp, "bg")
p = subprocess.run([binary, "batch", facecap, "--sample", "uniform", "--count", "8", "--seed", "5", "--active", "4", "--labels",
                    "segmentation", "--width", "96", "--height", "96", "--randomize", BG, "--archive", "tar", "-q", "-o", bg],
                   capture_output=True, text=True)
named, behind = {}, []
with tarfile.open(os.path.join(bg, "shard-000000.tar")) as t:
    for m in t.getmembers():
        key, suffix = m.name.split(".", 1)
        named.setdefault(key, {})[suffix] = t.extractfile(m).read()
for key, files in sorted(named.items()):
    picture = json.loads(files["json"]).get("background_image")
    w, h, ch, rows = read_png(files["png"])
    _, _, _, seg = read_png(files["seg.png"])
    # Each background pixel (segment 0) is the picture there: plain red, or the checker scaled x2 to cover 96².
    for x, y in ((8, 8), (88, 8), (40, 40), (8, 88)):  # Inside a square of the checker, not on an edge.
        if seg[y][x] != 0:
            continue
        want = (200, 30, 30) if picture == "plain.png" else ((230, 200, 40) if ((x // 2) // 8 + (y // 2 + 24) // 8) % 2 else (30, 90, 160))
        behind.append((picture, max(abs(rows[y][ch * x + c] - want[c]) for c in range(3)), rows[y][ch * x + 3] if ch == 4 else 255))
pictures_used = {json.loads(f["json"]).get("background_image") for f in named.values()}
check(f"background pictures from a folder: each sample names its picture ({sorted(pictures_used)}), every background pixel is it "
      f"(largest difference {max(d for _, d, _ in behind) if behind else None} of 255 over {len(behind)} pixels), opaque",
      p.returncode == 0 and pictures_used == {"checker.png", "plain.png"} and behind and all(d <= 3 and a == 255 for _, d, a in behind))
with open(os.path.join(bg, "batch.json")) as f:
    check("batch.json names the folder's pictures (another folder is another batch)",
          [b["name"] for b in json.load(f)["background_images"]] == ["checker.png", "plain.png"])
empty = os.path.join(tmp, "no-pictures")
os.makedirs(empty)
p = subprocess.run([binary, "batch", facecap, "--sample", "uniform", "--count", "2", "--labels", "segmentation", "--randomize",
                    '{"background": {"images": "%s"}}' % empty,
                    "-q", "-o", os.path.join(tmp, "bg-empty")], capture_output=True, text=True)
check(f"a folder without pictures: refused naming the member ({p.stderr.strip()[:160]})",
      p.returncode == 2 and "/randomize/background/images" in p.stderr and "no pictures" in p.stderr)

# The route: the same members, the same refusals, a job whose shard downloads.
with open(os.path.join(tmp, "key"), "w") as f:
    f.write("k3y-for-dataset-tests\n")
store = os.path.join(tmp, "store")
os.makedirs(store)
shutil.copy(facecap, store)
shutil.copy(os.path.join(src, "assets/facecap/facecap.manifest.json"), store)
server = Server(binary, tmp, store=store)
auth = {"Authorization": "Bearer k3y-for-dataset-tests"}
url = server.url + "/v1/rigs/facecap/batch"
st, _, body, hdr = request(url, "POST", json.dumps({"sample": {"method": "uniform", "count": 2}, "labels": ["depth", "albedo"]}).encode(), auth)
problem = json.loads(body) if body.startswith(b"{") else {}
check(f"POST batch labels [depth, albedo]: 422 problem+json at /labels/1 naming the labels ({st})", st == 422 and
      "application/problem+json" in hdr.get("Content-Type", "") and any(e.get("pointer") == "/labels/1" and "segmentation" in e.get("detail", "")
                                                                          for e in problem.get("errors", [])))
st, _, body, _ = request(url, "POST", json.dumps({"sample": {"method": "uniform", "count": 2}, "archive": "zip"}).encode(), auth)
check(f"POST batch archive zip: 422 naming the archives ({st})", st == 422 and b"tar" in body and b"/archive" in body)
st, _, body, _ = request(url, "POST", json.dumps({"sample": {"method": "uniform", "count": 2}, "labels": ["segmentation"],
                                                  "randomize": {"background": {"images": "/etc"}}}).encode(), auth)
check(f"POST batch with background images from a folder: 422, the service reads no folder a client names ({st})",
      st == 422 and b"/randomize/background/images" in body)
job_body = {"sample": {"method": "uniform", "count": 20, "seed": 5, "active": 4}, "labels": ["depth", "normals", "segmentation", "landmarks"],
            "archive": "tar", "shard_samples": 16, "width": 96, "height": 96, "randomize": json.loads(RANDOM)}
st, _, body, _ = request(url, "POST", json.dumps(job_body).encode(), auth)
job = json.loads(body) if st == 202 else {}
state = {}
for _ in range(600):
    if not job:
        break
    st2, _, b2, _ = request(server.url + job["links"]["self"])
    state = json.loads(b2) if st2 == 200 else {}
    if state.get("state") in ("done", "failed", "cancelled", "lost"):
        break
    time.sleep(0.1)
st3, _, tar_bytes, _ = request(server.url + job.get("links", {}).get("files", "/") + "shard-000001.tar") if job else (0, 0, b"", {})
with open(os.path.join(tmp, "route.tar"), "wb") as f:
    f.write(tar_bytes)
try:
    with tarfile.open(os.path.join(tmp, "route.tar")) as t:
        keys = {m.name.split(".", 1)[0] for m in t.getmembers()}
except tarfile.TarError:
    keys = set()
check(f"POST batch with labels and archive tar: a job that ends done, its shard-000001.tar downloads and reads ({state.get('state')}, {len(keys)} keys)",
      state.get("state") == "done" and st3 == 200 and keys == {f"v{k:06d}" for k in range(16, 20)})
said = {k: state.get(k) for k in ("format", "labels", "archive")}
check(f"the job's status says what it makes: {said}",
      said == {"format": "png", "labels": ["depth", "normals", "segmentation", "landmarks"], "archive": "tar"})
st4, _, zip_bytes, _ = request(server.url + job.get("links", {}).get("self", "/") + "/results.zip") if job else (0, 0, b"", {})
try:
    zip_names = zipfile.ZipFile(io.BytesIO(zip_bytes)).namelist()
except zipfile.BadZipFile:
    zip_names = []
check(f"results.zip holds the manifest and both tar shards ({st4}: {zip_names})",
      st4 == 200 and {"manifest.jsonl", "shard-000000.tar", "shard-000001.tar"} <= set(zip_names))
huge = {"sample": {"method": "uniform", "count": 10000}, "labels": ["depth", "normals"], "width": 8192, "height": 8192, "archive": "tar"}
st5, _, body, hdr = request(url, "POST", json.dumps(huge).encode(), auth)
check(f"a labelled batch of 10,000 samples at 8192²: refused before any work for the disk it would take ({st5}, {body[:160]!r})",
      st5 == 507 and b"/sample/count" in body and "application/problem+json" in hdr.get("Content-Type", ""))
check("the server still serves", server.alive())
server.stop()

shutil.rmtree(tmp, ignore_errors=True)
print(f"{counts['passed']} passed, {counts['failed']} failed")
sys.exit(1 if counts["failed"] else 0)
