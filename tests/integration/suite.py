"""What the Python suites against the real server share (hostile_test.py, bounded_test.py): checks that
count, a free port, the server as a process, one request whose errors are answers too."""
import contextlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

counts = {"passed": 0, "failed": 0}


def ok(what):
    counts["passed"] += 1
    print("ok   " + what, flush=True)


def no(what):
    counts["failed"] += 1
    print("FAIL " + what, flush=True)


def check(what, cond):
    (ok if cond else no)(what)
    return cond


# Speed bars (a p99, "within 300 ms") are the machine's as much as the code's: in the test command they are
# figures, printed "fast" or "slow" beside the outcome checks, and fail nothing. The benchmarks run the same
# suites with FACESPACE_BARS=1 on the release binary, alone (tests/bench/bars.sh), and there they are held.
BARS = os.environ.get("FACESPACE_BARS") == "1"


def bar(what, cond):
    if BARS:
        return check("bar: " + what, cond)
    print(("fast " if cond else "slow ") + what, flush=True)
    return True


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


class Server:
    """`facespace serve` on 0.0.0.0 (so that 127.0.0.x are other client addresses), with a key file in `tmp`."""

    def __init__(self, binary, tmp, *extra, store=None, jobs=None):
        env = dict(os.environ)
        # Under ASan, no LeakSanitizer check at the server's exit: its tracer now and then crashes itself
        # there with the server's ~80 threads (see service_test.sh). ASan and UBSan stay on.
        if env.get("ASAN_OPTIONS"):
            env["ASAN_OPTIONS"] += ":detect_leaks=0"
        # A free port can be taken between free_port() and the server's bind (a client of a suite running
        # beside this one, given it as its ephemeral port): the server then exits at once, and another is tried.
        for _ in range(5):
            self.port = free_port()
            self.url = f"http://127.0.0.1:{self.port}"
            self.log = open(os.path.join(tmp, f"server-{self.port}.log"), "w")
            args = [binary, "serve", "--host", "0.0.0.0", "--port", str(self.port), "--store", store or os.path.join(tmp, f"store-{self.port}"),
                    "--jobs-dir", jobs or os.path.join(tmp, f"jobs-{self.port}"), "--api-key-file", os.path.join(tmp, "key"), "--quiet", *extra]
            self.proc = subprocess.Popen(args, stdout=self.log, stderr=subprocess.STDOUT, env=env)
            for _ in range(600):  # Ready: up, and its rigs encoded (/readyz is 503 while it warms up).
                try:
                    urllib.request.urlopen(self.url + "/readyz", timeout=1).read()
                    break
                except OSError:  # Refused, or HTTPError 503.
                    if self.proc.poll() is not None:
                        break
                    time.sleep(0.1)
            if self.proc.poll() is None or "cannot listen" not in open(self.log.name, errors="replace").read():
                break
            self.log.close()
        self.idle = self.rss()

    def rss(self):
        """MB resident, 0 when gone."""
        try:
            with open(f"/proc/{self.proc.pid}/status") as f:
                return next(int(l.split()[1]) / 1024.0 for l in f if l.startswith("VmRSS:"))
        except (OSError, StopIteration):
            return 0.0

    def cpu(self):
        """CPU-seconds so far (user + system, all threads)."""
        try:
            with open(f"/proc/{self.proc.pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except OSError:
            return 0.0

    def alive(self):
        if self.proc.poll() is not None:
            return False
        try:
            return urllib.request.urlopen(self.url + "/healthz", timeout=5).status == 200
        except OSError:
            return False

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        self.log.close()
        return self.proc.returncode


def request(url, method="GET", body=None, headers=None, timeout=60):
    """(status, seconds, body bytes, headers) of one request; errors are answers too."""
    h = {"Content-Type": "application/json"} if body is not None else {}
    h.update(headers or {})
    t = time.time()
    req = urllib.request.Request(url, data=body, headers=h, method=method)
    try:
        r = urllib.request.urlopen(req, timeout=timeout)
        return r.status, time.time() - t, r.read(), dict(r.headers)
    except urllib.error.HTTPError as e:
        return e.code, time.time() - t, e.read(), dict(e.headers)
    except OSError as e:
        return 0, time.time() - t, str(e).encode(), {}


def probe_p99(url, n=40, paths=("/healthz",), pause=0.02):
    """(p99, median) seconds of `n` probes going round `paths`; a probe not answered within 5 s counts 99 s."""
    times = []
    for i in range(n):
        t = time.time()
        try:
            urllib.request.urlopen(url + paths[i % len(paths)], timeout=5).read()
            times.append(time.time() - t)
        except OSError:
            times.append(99.0)
        time.sleep(pause)
    times.sort()
    return times[min(len(times) - 1, int(0.99 * len(times)))], times[len(times) // 2]


@contextlib.contextmanager
def served(binary, src, key, prefix, *extra):
    """`facespace serve` on the bundled rigs with the API key `key` (a file in a fresh folder): (server, folder),
    the server stopped after, however the block ends."""
    tmp = tempfile.mkdtemp(prefix=prefix)
    with open(os.path.join(tmp, "key"), "w") as f:
        f.write(key + "\n")
    srv = Server(binary, tmp, "--rigs", os.path.join(src, "assets"), *extra)
    try:
        yield srv, tmp
    finally:
        srv.stop()


def finish():
    """The counts, and the exit: 1 when any check failed."""
    print(f"{counts['passed']} passed, {counts['failed']} failed")
    sys.exit(1 if counts["failed"] else 0)
