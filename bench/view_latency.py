#!/usr/bin/env python3
"""rendr view's preview latency (issue #22): from sending a render request to having
the PNG bytes, for a 256x256 preview of the bundled head MRI, lit `over` (early ray termination at
opacity 0.99, the viewer's default), bspln3, 2 threads. Starts `rendr view` (the release build), sends N requests (each camera
turned a little from the last, as a drag does), prints the median and quartiles.

usage: bench/view_latency.py [N] [rendr binary]   (default 40, target/release/rendr)
"""
import json, math, os, statistics, subprocess, sys, time, http.client

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
n = int(sys.argv[1]) if len(sys.argv) > 1 else 40
rendr = sys.argv[2] if len(sys.argv) > 2 else os.path.join(root, "target/release/rendr")
data = os.path.join(root, "data")
p = subprocess.Popen([rendr, "view", os.path.join(data, "itk-t1-head.nrrd"), "-port", "0"],
                     stdout=subprocess.PIPE, text=True)
try:
    url = p.stdout.readline().strip().split("http://", 1)[1]
    addr, token = url.split("/?t=")
    host, port = addr.rsplit(":", 1)
    rgb = open(os.path.join(data, "skin-rgb.txt")).read()
    alpha = open(os.path.join(data, "skin-alpha.txt")).read()
    lights = open(os.path.join(data, "head-lights.txt")).read()
    at = (-127.0, -162.5, 110.0)
    times = []
    for i in range(n + 3):
        a = 0.3 + 0.02 * i                       # orbit about z through the look-at point
        fr = (at[0] + 480 * math.cos(a), at[1] + 480 * math.sin(a), 260.0)
        args = ["-k", "bspln3", "-p", "rgbalit", "-b", "over", "-s", "1", "-us", "2", "-a1", "0.99",
                "-sz", "256", "256", "-nt", "2", "-fr", *map(repr, fr), "-at", *map(repr, at),
                "-up", "0", "0", "1", "-nc", "-150", "-fc", "150", "-fov", "30"]
        body = json.dumps({"client": "bench", "seq": i + 1, "args": args,
                           "txf": {"rgb": rgb, "alpha": alpha, "mm": [0, 255], "len": 256},
                           "lights": lights})
        c = http.client.HTTPConnection(host, int(port))
        t0 = time.perf_counter()
        c.request("POST", "/render?t=" + token, body=body,
                  headers={"Content-Type": "application/json", "Host": addr})
        r = c.getresponse()
        png = r.read()
        dt = time.perf_counter() - t0
        c.close()
        if r.status != 200 or png[1:4] != b"PNG":
            sys.exit(f"request {i}: {r.status} {png[:200]!r}")
        if i >= 3:                               # the first three warm the caches
            times.append(dt * 1000)
    q = statistics.quantiles(times, n=4)
    print(f"rendr view preview latency, 256x256 head MRI, rgbalit over -a1 0.99, bspln3, 2 threads, "
          f"{len(times)} requests: median {statistics.median(times):.1f} ms "
          f"(quartiles {q[0]:.1f} / {q[2]:.1f} ms, min {min(times):.1f}, max {max(times):.1f})")
finally:
    p.kill()
    p.wait()
