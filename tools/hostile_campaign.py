#!/usr/bin/env python3
"""Hostile-input campaign against the tiltfield binary (issue 24, "hostile input, round two").

Generates about 1,200 runs of bad input (CLI numbers at the edge, files that are not files,
truncated and corrupt PNG/EXR/PFM/JSON/INI/glTF, mismatched and missing views, odd outputs,
hostile viewer scripts, a damaged or planted depth cache), runs each in its own temporary
folder under `ulimit -v 8000000` and `timeout -s KILL 60`, classifies it and prints a summary
table per class and per command. Every run that is not a clean error or a checked acceptance
goes to the findings file with its command line, exit status and the tail of stderr.

    tools/hostile_campaign.py --bin target/debug/tiltfield --work /tmp/hc
    tools/hostile_campaign.py --bin … --work /tmp/hc --group numbers --group files
    tools/hostile_campaign.py --bin … --work /tmp/hc --list-groups
    tools/hostile_campaign.py --bin … --work /tmp/hc --summary      # table from results so far

Results are appended to WORK/results.jsonl as runs finish, so a campaign can be stopped and
resumed (cases already in the file are skipped; --fresh starts over). Cases are deterministic
(seeded), so a case id names the same run every time.

Classes:
  clean      non-zero exit (1 or 2), an error message, no "panicked", no backtrace
  accepted   exit 0 and every expected output exists and is valid (decoded, finite values)
  panic      "panicked" in stderr or exit 101
  abort      killed by a signal or exit >= 128 (not the timeout)
  hang       killed by the 60 s timeout
  lost       exit 0 but an output is missing, empty, unreadable, all-NaN or fully transparent,
             or "wrote X" printed for an X that is not there, or a write into a device/full disk
             reported as success
  validation a Vulkan validation-layer message in the output
  leftover   a failed run left files behind (or a run wrote outside its folder / through a link)
  unclear    non-zero exit without a one-line error, or the message does not name what the case
             expects (a candidate misleading message; triage by hand)
  accepted?  exit 0 where the case expected a refusal; outputs valid (triage by hand)

Needs python3 with numpy and Pillow; mkfifo; optionally xvfb-run for a few viewer runs.
Environment passed to every run: VK_DRIVER_FILES (lavapipe unless set), TILTFIELD_VALIDATION=1,
TILTFIELD_CACHE_DIR inside the run's folder (unless the case sets its own), no DISPLAY.
"""

import argparse
import base64
import collections
import concurrent.futures
import io
import json
import os
import random
import re
import shlex
import shutil
import struct
import subprocess
import sys
import time
import zlib

import numpy as np
from PIL import Image

TIMEOUT = 60
ULIMIT_KB = 8000000
LVP = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json"

# --------------------------------------------------------------------------------------------
# Fixtures: small valid light fields built once, copied into each run's folder and damaged there.
# --------------------------------------------------------------------------------------------


def run_ok(argv, env, cwd=None):
    p = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, timeout=300)
    if p.returncode != 0:
        raise SystemExit(f"fixture command failed: {shlex.join(argv)}\n{p.stderr}")
    return p


def textured(w, h, seed):
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 255, size=(h // 4 + 1, w // 4 + 1, 3), dtype=np.uint8)
    img = np.kron(base, np.ones((4, 4, 1), dtype=np.uint8))[:h, :w]
    return Image.fromarray(img, "RGB")


def make_video(dst, frames=(1, 2, 3), cams=4, w=32, h=24, scene="S", undist=True):
    os.makedirs(dst, exist_ok=True)
    lines = ["f cu cv ar sk qw qx qy qz tx ty tz"]
    for k in range(cams):
        lines.append(f"28 {(w - 1) / 2} {(h - 1) / 2} 1 0 1 0 0 0 {-0.1 * k} 0 0")
    with open(os.path.join(dst, "cameras_parameters.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")
    base = np.array(textured(w + 8 * cams, h, 7))
    for fr in frames:
        for k in range(cams):
            img = Image.fromarray(base[:, 8 * k + fr % 3: 8 * k + fr % 3 + w].copy(), "RGB")
            name = f"{scene}_undist_{fr:05d}_{k:02d}.png" if undist else f"{scene}_{fr:05d}_{k:02d}.png"
            img.save(os.path.join(dst, name))


def build_fixtures(fx, binary, env):
    if os.path.exists(os.path.join(fx, ".done")):
        return
    shutil.rmtree(fx, ignore_errors=True)
    os.makedirs(fx)
    run_ok([binary, "synth", "builtin:demo", "--out", f"{fx}/hci", "--grid", "3x3", "--size", "48x48"], env)
    run_ok([binary, "synth", "builtin:planes", "--out", f"{fx}/man", "--layout", "manifest",
            "--grid", "3x3", "--size", "32x32"], env)
    # A grid folder (no calibration, no depth: depth is estimated and cached).
    os.makedirs(f"{fx}/grid")
    for i in range(9):
        t, s = divmod(i, 3)
        shutil.copy(f"{fx}/hci/input_Cam{i:03d}.png", f"{fx}/grid/view_{t:02d}_{s:02d}.png")
    make_video(f"{fx}/video")
    shutil.copy(os.path.join(REPO, "tests/data/example.gltf"), f"{fx}/example.gltf")
    shutil.copy(os.path.join(REPO, "tests/data/example.glb"), f"{fx}/example.glb")
    # The example glTF with its buffer in a file of its own (ext.gltf + example.bin).
    g = json.load(open(f"{fx}/example.gltf"))
    uri = g["buffers"][0]["uri"]
    open(f"{fx}/example.bin", "wb").write(base64.b64decode(uri.split(",", 1)[1]))
    g["buffers"][0]["uri"] = "example.bin"
    json.dump(g, open(f"{fx}/ext.gltf", "w"))
    # A populated depth cache for the grid folder (key depends on the content only).
    cenv = dict(env, TILTFIELD_CACHE_DIR=f"{fx}/cache")
    run_ok([binary, "cloud", f"{fx}/grid", "-o", f"{fx}/seed.ply"], cenv)
    open(os.path.join(fx, ".done"), "w").close()


REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# --------------------------------------------------------------------------------------------
# Cases
# --------------------------------------------------------------------------------------------


class Case:
    def __init__(self, cid, group, cmd, argv, setup=None, outputs=(), expect="any", words=(),
                 env=None, post=None, xvfb=False, followup=None):
        self.cid = cid          # unique, stable id
        self.group = group      # campaign group
        self.cmd = cmd          # tiltfield command (for the table)
        self.argv = argv        # arguments after the binary; "{D}" = run folder, "{F}" = fixtures
        self.setup = setup      # function(run_dir, fixtures_dir)
        self.outputs = outputs  # (path, kind) expected when exit 0; kind png|png_any|pfm|exr|ply|json|dir_hci|dir_man|nonempty
        self.expect = expect    # "fail": exit 0 is suspicious; "ok": a failure is unclear; "any"
        self.words = words      # an error should contain one of these (case-insensitive)
        self.env = env or {}
        self.post = post        # function(run_dir, fixtures_dir, rc) -> problem string or None
        self.xvfb = xvfb
        self.followup = followup  # argv run after exit 0 (e.g. info on what synth wrote); must exit 0


def cp(src, name=None):
    def f(d, fx):
        s = os.path.join(fx, src)
        t = os.path.join(d, name or src)
        if os.path.isdir(s):
            shutil.copytree(s, t, symlinks=True)
        else:
            shutil.copy(s, t)
    return f


def chain(*fs):
    def f(d, fx):
        for g in fs:
            if g:
                g(d, fx)
    return f


def write(rel, data):
    def f(d, fx):
        p = os.path.join(d, rel)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        if isinstance(data, str):
            open(p, "w", encoding="utf-8", newline="").write(data)
        else:
            open(p, "wb").write(data)
    return f


def remove(rel):
    def f(d, fx):
        p = os.path.join(d, rel)
        if os.path.isdir(p) and not os.path.islink(p):
            shutil.rmtree(p)
        elif os.path.lexists(p):
            os.remove(p)
    return f


def special(rel, kind):
    """Replace d/rel by a thing that is not a regular file."""
    def f(d, fx):
        p = os.path.join(d, rel)
        remove(rel)(d, fx)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        if kind == "dir":
            os.mkdir(p)
        elif kind == "fifo":
            os.mkfifo(p)
        elif kind == "dangling":
            os.symlink(os.path.join(d, "nowhere", "missing"), p)
        elif kind == "devzero":
            os.symlink("/dev/zero", p)
        elif kind == "devnull":
            os.symlink("/dev/null", p)
        elif kind == "devurandom":
            os.symlink("/dev/urandom", p)
        elif kind == "empty":
            open(p, "wb").close()
        elif kind == "loop":
            os.symlink(p, p)
        elif kind == "selfdir":
            os.symlink(".", p)
        else:
            raise ValueError(kind)
    return f


SPECIAL_KINDS = ["dir", "fifo", "dangling", "devzero", "devnull", "empty", "loop"]
SPECIAL_WORDS = {
    "dir": ("folder", "directory"), "fifo": ("fifo", "pipe"), "dangling": ("link", "missing", "not exist", "no such"),
    "devzero": ("device", "character"), "devnull": ("device", "character", "empty"), "empty": ("empty", "0 bytes", "truncated", "eof", "end of", "no ", "missing"),
    "loop": ("link", "loop", "symbolic"), "devurandom": ("device", "character"),
}


def mutate(data, rng, how):
    b = bytearray(data)
    n = len(b)
    if n == 0:
        return bytes(b)
    if how == "trunc":
        return bytes(b[: rng.randrange(0, n)])
    if how == "flip":
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(n)
            b[i] ^= 1 << rng.randrange(8)
        return bytes(b)
    if how == "junk":
        i = rng.randrange(n)
        j = min(n, i + rng.randint(1, 64))
        b[i:j] = bytes(rng.randrange(256) for _ in range(j - i))
        return bytes(b)
    if how == "insert":
        i = rng.randrange(n)
        return bytes(b[:i]) + bytes(rng.randrange(256) for _ in range(rng.randint(1, 32))) + bytes(b[i:])
    if how == "dup":
        i = rng.randrange(n)
        j = min(n, i + rng.randint(1, 200))
        return bytes(b[:j]) + bytes(b[i:j]) * rng.randint(1, 50) + bytes(b[j:])
    if how == "zero_tail":
        i = rng.randrange(n)
        return bytes(b[:i]) + b"\0" * (n - i)
    raise ValueError(how)


def mutate_text(text, rng):
    """Mutations that keep a text file text-like: numbers swapped for edge values, lines cut."""
    edges = ["0", "-1", "NaN", "nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "18446744073709551615",
             "99999999999999999999999999", "", "x", "0x10", "1,5", "١", "4294967296", "-0", "+5", "1e", "."]
    nums = list(re.finditer(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", text))
    how = rng.choice(["num", "num", "num", "dropline", "dupline", "bom", "crlf", "nul", "unicode", "swapkey"])
    if how == "num" and nums:
        m = rng.choice(nums)
        return text[: m.start()] + rng.choice(edges) + text[m.end():]
    lines = text.split("\n")
    if how == "dropline" and len(lines) > 1:
        del lines[rng.randrange(len(lines))]
        return "\n".join(lines)
    if how == "dupline":
        i = rng.randrange(len(lines))
        lines.insert(i, lines[i])
        return "\n".join(lines)
    if how == "bom":
        return "\ufeff" + text
    if how == "crlf":
        return text.replace("\n", "\r\n")
    if how == "nul":
        i = rng.randrange(len(text) + 1)
        return text[:i] + "\0" + text[i:]
    if how == "unicode":
        i = rng.randrange(len(text) + 1)
        return text[:i] + rng.choice(["é", "\u202e", "\ud7ff", "𝟘", "\u00a0"]) + text[i:]
    if how == "swapkey":
        return text.replace("=", " ", 1).replace(":", "", 1)
    return text


def damage_file(rel, fn):
    """Rewrite d/rel with fn(bytes) -> bytes."""
    def f(d, fx):
        p = os.path.join(d, rel)
        data = open(p, "rb").read()
        open(p, "wb").write(fn(data))
    return f


def png_bytes(w, h, mode="RGB", seed=0, bits=8):
    if bits == 16:
        arr = (np.random.default_rng(seed).integers(0, 65535, size=(h, w), dtype=np.uint16))
        img = Image.fromarray(arr)
    else:
        img = textured(w, h, seed).convert(mode)
    bio = io.BytesIO()
    img.save(bio, "PNG")
    return bio.getvalue()


def png_chunk(t, data):
    return struct.pack(">I", len(data)) + t + data + struct.pack(">I", zlib.crc32(t + data) & 0xFFFFFFFF)


def png_header_only(w, h):
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", zlib.compress(b"\0" * 16)) + png_chunk(b"IEND", b"")


def pfm_bytes(w, h, values=None, scale=-1.0, header=None):
    if values is None:
        values = np.full((h, w), 0.1, dtype="<f4")
    hdr = header if header is not None else f"Pf\n{w} {h}\n{scale}\n".encode()
    return hdr + np.asarray(values, dtype="<f4").tobytes()


# Values at the edge for numeric options.
FLOATS = ["0", "-1", "NaN", "inf", "-inf", "1e308", "-1e308", "1e-308", "18446744073709551615", "", "garbage",
          "0x10", "1e999", "-0"]
INTS = ["0", "-1", "1", "NaN", "inf", "1e308", "4294967296", "18446744073709551615", "18446744073709551616",
        "99999999999999999999999", "", "garbage", "2147483648", "65536"]
PAIRS = ["0x0", "1x1", "-1x5", "0x64", "NaNxNaN", "99999x99999", "8193x8", "8192x8192", "18446744073709551615x1",
         "4294967297x1", "x", "", "64", "64x", "64x64x64", "1e3x1e3", "32X32", " 32x32"]
ST = ["0,0", "-1,-1", "NaN,0", "inf,inf", "1e308,1e308", "2,2", "3,3", "1", "1,2,3", "", ",", "a,b",
      "18446744073709551615,0", "-0,-0", "1.5,0.5"]
UV = ["0,0", "-1,-1", "NaN,NaN", "inf,0", "1e308,1e308", "47,47", "48,48", "100000,0", "", "1", "a,b",
      "18446744073709551615,1", "24.5,24.5"]


def O(d, name):  # an output path in the run folder
    return os.path.join(d, name)


def cases():
    C = []
    add = C.append
    HCI = "{D}/hci"
    # ---------------- numbers: every numeric option at the edge --------------------------------
    render_scalar = [
        ("--disparity", FLOATS, []),
        ("--focus", FLOATS, []),
        ("--tilt", FLOATS, ["--focus", "2.5"]),
        ("--swing", FLOATS, ["--focus", "2.5"]),
        ("--aperture-radius", FLOATS, ["--disparity", "0"]),
        ("--antialias-samples", INTS, ["--disparity", "0", "--antialias", "on"]),
        ("--views-per-draw", INTS, ["--disparity", "0", "--strategy", "batched"]),
        ("--repeat", INTS, ["--disparity", "0"]),
        ("--nudge-distance", FLOATS, ["--click", "24,24"]),
        ("--nudge-tilt", FLOATS, ["--click", "24,24"]),
        ("--nudge-swing", FLOATS, ["--click", "24,24"]),
        ("--normal-window", INTS, ["--click", "24,24"]),
    ]
    for opt, vals, extra in render_scalar:
        for i, v in enumerate(vals):
            add(Case(f"num-render{opt}-{i}", "numbers", "render",
                     ["render", HCI, "-o", "{D}/o.png", *extra, f"{opt}={v}"], setup=cp("hci"),
                     outputs=[("o.png", "png")], words=(opt.lstrip("-"), opt.lstrip("-").replace("-", " "), "value", "invalid")))
    for opt, vals in [("--focal-px", FLOATS), ("--baseline", FLOATS)]:
        for i, v in enumerate(vals):
            add(Case(f"num-render-grid{opt}-{i}", "numbers", "render",
                     ["render", "{D}/grid", "-o", "{D}/o.png", "--disparity", "0.5", f"{opt}={v}"], setup=cp("grid"),
                     outputs=[("o.png", "png")], words=(opt.lstrip("-"), opt.lstrip("-").replace("-", " "), "value", "invalid")))
    for i, v in enumerate(PAIRS):
        add(Case(f"num-render--size-{i}", "numbers", "render",
                 ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", f"--size={v}"], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("size",)))
    for i, v in enumerate(ST):
        add(Case(f"num-render--view-{i}", "numbers", "render",
                 ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", f"--view={v}"], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("view",)))
    for i, v in enumerate(UV):
        add(Case(f"num-render--click-{i}", "numbers", "render",
                 ["render", HCI, "-o", "{D}/o.png", f"--click={v}"], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("click", "pixel", "u,v")))
    for i, v in enumerate(["0,0,10,10,0,10", "0,0,0,0,0,0", "0,0,1,1,2,2", "NaN,0,1,1,2,2", "1e308,0,1,0,0,1",
                           "-5,-5,10,10,0,10", "1,2,3", "", "5,5,40,5,5,40", "47,47,0,47,47,0"]):
        add(Case(f"num-render--points-{i}", "numbers", "render",
                 ["render", HCI, "-o", "{D}/o.png", f"--points={v}"], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("points", "point")))
    for i, v in enumerate(["0,0,2,0,0,1", "0,0,0,0,0,0", "0,0,2,NaN,0,1", "0,0,1e308,0,0,1", "0,0,-2,0,0,1",
                           "0,0,2,1,0,0", "0,0,2,0,0,1e-308", "1,2,3", "", "inf,0,2,0,0,1"]):
        add(Case(f"num-render--plane-{i}", "numbers", "render",
                 ["render", HCI, "-o", "{D}/o.png", f"--plane={v}"], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("plane", "normal")))
    for i, v in enumerate(["0,0,2,1,0,2,0,1,2", "0,0,2,0,0,2,0,0,2", "0,0,2,1,0,2,2,0,2", "NaN,0,2,1,0,2,0,1,2",
                           "1e308,0,2,1,0,2,0,1,2", "0,0,-2,1,0,-2,0,1,-2", "1,2"]):
        add(Case(f"num-render--points-3d-{i}", "numbers", "render",
                 ["render", HCI, "-o", "{D}/o.png", f"--points-3d={v}"], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("points", "point", "collinear", "plane")))
    # depth
    for opt, vals in [("--planes", INTS), ("--radius", INTS)]:
        for i, v in enumerate(vals):
            add(Case(f"num-depth{opt}-{i}", "numbers", "depth", ["depth", HCI, "-o", "{D}/d.pfm", f"{opt}={v}"],
                     setup=cp("hci"), outputs=[("d.pfm", "pfm")], words=(opt.lstrip("-"), "value")))
    for i, v in enumerate(["0,1", "1,0", "-1,1", "NaN,1", "-inf,inf", "1e-308,1e308", "-1e308,1e308", "0,0", "1",
                           "", "5,5", "-100,100", "1,2,3"]):
        add(Case(f"num-depth--range-{i}", "numbers", "depth", ["depth", HCI, "-o", "{D}/d.pfm", f"--range={v}"],
                 setup=cp("hci"), outputs=[("d.pfm", "pfm")], words=("range",)))
        add(Case(f"num-depth--range-depth-{i}", "numbers", "depth",
                 ["depth", HCI, "-o", "{D}/d.pfm", "--kind", "depth", f"--range={v}"],
                 setup=cp("hci"), outputs=[("d.pfm", "pfm")], words=("range",)))
    for i, v in enumerate(["cross:0", "cross:-1", "cross:99999", "square:0", "square:18446744073709551615", "cross:",
                           "square:NaN", "all", "bogus", "", "cross:1", "square:1"]):
        add(Case(f"num-depth--views-{i}", "numbers", "depth", ["depth", HCI, "-o", "{D}/d.pfm", f"--views={v}"],
                 setup=cp("hci"), outputs=[("d.pfm", "pfm")], words=("views", "cross", "square")))
    for i, v in enumerate(ST):
        add(Case(f"num-depth--view-{i}", "numbers", "depth", ["depth", HCI, "-o", "{D}/d.pfm", f"--view={v}"],
                 setup=cp("hci"), outputs=[("d.pfm", "pfm")], words=("view",)))
    # synth (small by default)
    SY = ["synth", "builtin:planes", "--out", "{D}/out"]
    small = ["--grid", "3x3", "--size", "32x32"]
    for opt, vals in [("--baseline", FLOATS), ("--focal-mm", FLOATS), ("--sensor-mm", FLOATS),
                      ("--focus-distance", FLOATS), ("--gt-aperture-radius", FLOATS), ("--disparity", FLOATS),
                      ("--samples", INTS), ("--gt-samples", INTS)]:
        for i, v in enumerate(vals):
            add(Case(f"num-synth{opt}-{i}", "numbers", "synth", SY + small + [f"{opt}={v}"],
                     outputs=[("out", "dir_hci")], words=(opt.lstrip("-"), opt.lstrip("-").replace("-", " "), "value"),
                     followup=["info", "{D}/out"]))
    for i, v in enumerate(FLOATS):
        add(Case(f"num-synth--converge-distance-{i}", "numbers", "synth",
                 SY + small + ["--layout", "manifest", "--rig", "converging", f"--converge-distance={v}"],
                 outputs=[("out", "dir_man")], words=("converge",), followup=["info", "{D}/out"]))
    for i, v in enumerate(PAIRS):
        add(Case(f"num-synth--grid-{i}", "numbers", "synth", SY + ["--size", "32x32", f"--grid={v}"],
                 outputs=[("out", "dir_hci")], words=("grid",), followup=["info", "{D}/out"]))
        add(Case(f"num-synth--size-{i}", "numbers", "synth", SY + ["--grid", "2x2", f"--size={v}"],
                 outputs=[("out", "dir_hci")], words=("size",), followup=["info", "{D}/out"]))
    # cloud
    for opt, vals, extra in [("--stride", INTS, []), ("--plane-size", FLOATS, ["--focus", "2.5"]),
                             ("--normal-window", INTS, [])]:
        for i, v in enumerate(vals):
            add(Case(f"num-cloud{opt}-{i}", "numbers", "cloud", ["cloud", HCI, "-o", "{D}/c.ply", *extra, f"{opt}={v}"],
                     setup=cp("hci"), outputs=[("c.ply", "ply")], words=(opt.lstrip("-"), opt.lstrip("-").replace("-", " "))))
    for i, v in enumerate(UV):
        add(Case(f"num-cloud--click-{i}", "numbers", "cloud", ["cloud", HCI, "-o", "{D}/c.ply", f"--click={v}"],
                 setup=cp("hci"), outputs=[("c.ply", "ply")], words=("click", "pixel")))
    # bench --quick
    for i, v in enumerate(["0", "-1", "1", "1001", "18446744073709551615", "NaN", ""]):
        add(Case(f"num-bench--frames-{i}", "numbers", "bench",
                 ["bench", HCI, "--quick", "--no-scaling", "--disparity", "0", "--out", "{D}/b", f"--frames={v}"],
                 setup=cp("hci"), outputs=[("b/bench.json", "json")], words=("frames",)))
    for i, v in enumerate(["0x0", "99999x99999", "33000x33000", "4096x4096", "2049x2", "64x64", "bogus", "", "x,y",
                           "64x64,NaNx3", "18446744073709551615x2"]):
        add(Case(f"num-bench--variants-{i}", "numbers", "bench",
                 ["bench", HCI, "--quick", "--no-scaling", "--disparity", "0", "--out", "{D}/b", f"--variants={v}"],
                 setup=cp("hci"), outputs=[("b/bench.json", "json")], words=("variant", "size", "2048")))
    for opt in ["--peak-gtexels", "--peak-gbps"]:
        for i, v in enumerate(["0", "-1", "NaN", "inf", "1e308", ""]):
            add(Case(f"num-bench{opt}-{i}", "numbers", "bench",
                     ["bench", HCI, "--quick", "--no-scaling", "--disparity", "0", "--out", "{D}/b", f"{opt}={v}"],
                     setup=cp("hci"), outputs=[("b/bench.json", "json")], words=(opt.lstrip("-"), "peak")))
    # depth-set
    for i, v in enumerate(["0", "1", "2", "4", "10", "-3", "NaN", "18446744073709551615", ""]):
        add(Case(f"num-depth-set--grid-{i}", "numbers", "depth-set",
                 ["depth-set", "--scenes", "planes", "--variants", "sweep", "--size", "48", f"--grid={v}"],
                 words=("grid",)))
    for i, v in enumerate(["0", "47", "513", "-48", "NaN", "18446744073709551615", ""]):
        add(Case(f"num-depth-set--size-{i}", "numbers", "depth-set",
                 ["depth-set", "--scenes", "planes", "--variants", "sweep", "--grid", "3", f"--size={v}"],
                 words=("size",)))
    for i, v in enumerate(["", ",", "planes,planes", "PLANES", "zz", "planes,", "plenoptic"]):
        add(Case(f"num-depth-set--scenes-{i}", "numbers", "depth-set",
                 ["depth-set", "--grid", "3", "--size", "48", "--variants", "sweep", f"--scenes={v}"],
                 words=("scene",)))
    for i, v in enumerate(["", ",", "bogus", "sweep,sweep", "naive"]):
        add(Case(f"num-depth-set--variants-{i}", "numbers", "depth-set",
                 ["depth-set", "--grid", "3", "--size", "48", "--scenes", "planes", f"--variants={v}"],
                 words=("variant",)))
    # demo
    for i, v in enumerate(["0", "17", "-1", "NaN", "18446744073709551615", ""]):
        add(Case(f"num-demo--antialias-samples-{i}", "numbers", "demo",
                 ["demo", "-o", "{D}/demo", "--scene", "planes", f"--antialias-samples={v}"],
                 outputs=[("demo/demo.json", "json")], words=("samples",)))
    for i, v in enumerate(["", "bogus", "builtin:demo", "../planes", "PLANES"]):
        add(Case(f"num-demo--scene-{i}", "numbers", "demo", ["demo", "-o", "{D}/demo", f"--scene={v}"],
                 outputs=[("demo/demo.json", "json")], words=("scene",)))
    # info/render --frame and --frames on the video
    for i, v in enumerate(["0", "1", "3", "4", "-1", "18446744073709551615", "18446744073709551616", "NaN", ""]):
        add(Case(f"num-info--frame-{i}", "numbers", "info", ["info", "{D}/video", f"--frame={v}"], setup=cp("video"),
                 words=("frame",)))
        add(Case(f"num-info-hci--frame-{i}", "numbers", "info", ["info", HCI, f"--frame={v}"], setup=cp("hci"),
                 expect="fail", words=("frame", "video")))
    for i, v in enumerate(["1..3", "1..", "..3", "3..1", "0..0", "2..2", "..", "1..4", "-1..2", "1...3", "1..3..5",
                           "18446744073709551615..", "..18446744073709551615", "18446744073709551614..18446744073709551615",
                           "", "a..b", "1..18446744073709551616", "NaN..3"]):
        add(Case(f"num-render--frames-{i}", "numbers", "render",
                 ["render", "{D}/video", "--frames", v, "--disparity", "0", "-o", "{D}/f_{frame}.png"], setup=cp("video"),
                 outputs=[("f_*.png", "glob_png")], words=("frame",)))
    for i, v in enumerate(["f.png", "f_{frame:999}.png", "f_{frame:05}.png", "f_{frame}{frame}.png", "f_{frame.png",
                           "f_{frame:-1}.png", "f_{frame:x}.png", "{frame}/f.png", "f_{frame}.jpg"]):
        add(Case(f"num-render--frames-pattern-{i}", "numbers", "render",
                 ["render", "{D}/video", "--frames", "1..2", "--disparity", "0", "-o", "{D}/" + v], setup=cp("video"),
                 outputs=[("*", "any_png")], words=("frame", "output", "-o", "png")))
    # view: numbers are checked or the display is refused; no DISPLAY here
    for opt, vals in [("--frame-budget-ms", FLOATS), ("--window", PAIRS)]:
        for i, v in enumerate(vals[:10]):
            add(Case(f"num-view{opt}-{i}", "numbers", "view", ["view", HCI, "--disparity", "0", f"{opt}={v}"],
                     setup=cp("hci"), expect="fail", words=(opt.lstrip("-"), "display", "window", "budget")))

    # ---------------- files that are not files -----------------------------------------------
    slots = [
        # (id, fixture, path inside, argv, words)
        ("hci-params", "hci", "hci/parameters.cfg", ["info", HCI], ("parameters.cfg",)),
        ("hci-view", "hci", "hci/input_Cam004.png", ["render", HCI, "-o", "{D}/o.png", "--disparity", "0"], ("input_Cam004",)),
        ("hci-view0", "hci", "hci/input_Cam000.png", ["info", HCI], ("input_Cam000",)),
        ("hci-gtdisp", "hci", "hci/gt_disp_lowres.pfm", ["render", HCI, "-o", "{D}/o.png", "--click", "20,20"], ("gt_disp",)),
        ("hci-gtdepth", "hci", "hci/gt_depth_lowres.pfm", ["cloud", HCI, "-o", "{D}/c.ply"], ("gt_depth",)),
        ("man-json", "man", "man/tiltfield.json", ["info", "{D}/man"], ("tiltfield.json",)),
        ("man-json-direct", "man", "man/tiltfield.json", ["info", "{D}/man/tiltfield.json"], ("tiltfield.json",)),
        ("man-image", "man", "man/view_1_1.png", ["render", "{D}/man", "-o", "{D}/o.png", "--disparity", "0"], ("view_1_1",)),
        ("man-depth", "man", "man/depth_1_1.pfm", ["render", "{D}/man", "-o", "{D}/o.png", "--click", "10,10"], ("depth_1_1",)),
        ("man-disp", "man", "man/disparity_1_1.pfm", ["cloud", "{D}/man", "-o", "{D}/c.ply"], ("disparity_1_1",)),
        ("grid-view", "grid", "grid/view_01_01.png", ["info", "{D}/grid"], ("view_01_01",)),
        ("video-params", "video", "video/cameras_parameters.txt", ["info", "{D}/video"], ("cameras_parameters",)),
        ("video-frame", "video", "video/S_undist_00002_01.png", ["render", "{D}/video", "--frame", "2", "-o", "{D}/o.png", "--disparity", "0"], ("S_undist_00002_01",)),
        ("gltf", None, "scene.gltf", ["synth", "{D}/scene.gltf", "--out", "{D}/out", "--grid", "2x2", "--size", "32x32"], ("scene.gltf",)),
        ("glb", None, "scene.glb", ["synth", "{D}/scene.glb", "--out", "{D}/out", "--grid", "2x2", "--size", "32x32"], ("scene.glb",)),
        ("score", "hci", "gt.pfm", ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/gt.pfm"], ("gt.pfm", "score")),
        ("script", "hci", "s.txt", ["view", HCI, "--disparity", "0", "--script", "{D}/s.txt"], ("s.txt", "script")),
        ("lf-arg", None, "lf", ["info", "{D}/lf"], ("lf",)),
        ("lf-json", None, "lf.json", ["render", "{D}/lf.json", "-o", "{D}/o.png", "--disparity", "0"], ("lf.json",)),
        ("markdown-in", None, "m", ["depth-set", "--hci", "{D}/m", "--scenes", "planes", "--grid", "3", "--size", "48", "--variants", "sweep"], ("m", "hci")),
    ]
    for sid, fixture, rel, argv, words in slots:
        for kind in SPECIAL_KINDS + ["devurandom", "selfdir"]:
            if sid in ("lf-arg",) and kind in ("dir", "selfdir"):
                continue
            setup = chain(cp(fixture) if fixture else None, special(rel, kind))
            add(Case(f"file-{sid}-{kind}", "files", argv[0], argv, setup=setup, expect="fail",
                     words=tuple(words) + SPECIAL_WORDS.get(kind, ())))
    for kind in SPECIAL_KINDS:
        add(Case(f"file-hci-gtboth-{kind}", "files", "render", ["render", HCI, "-o", "{D}/o.png", "--click", "20,20", "--json"],
                 setup=chain(cp("hci"), special("hci/gt_disp_lowres.pfm", kind), special("hci/gt_depth_lowres.pfm", kind)),
                 expect="fail", outputs=[("o.png", "png")], words=("gt_disp", "gt_depth")))
    # glTF buffer URIs that are not files
    for kind in SPECIAL_KINDS + ["devurandom"]:
        def setup(d, fx, kind=kind):
            g = json.load(open(os.path.join(fx, "ext.gltf")))
            g["buffers"][0]["uri"] = "buf.bin"
            json.dump(g, open(os.path.join(d, "scene.gltf"), "w"))
            special("buf.bin", kind)(d, fx)
        add(Case(f"file-gltf-buffer-{kind}", "files", "synth",
                 ["synth", "{D}/scene.gltf", "--out", "{D}/out", "--grid", "2x2", "--size", "32x32"], setup=setup,
                 expect="fail", words=("buf.bin",)))
    for j, uri in enumerate(["/dev/zero", "/dev/stdin", "/proc/self/mem", "/etc", "data:application/octet-stream;base64,@@@@",
                             "data:,", "data:application/octet-stream;base64," + base64.b64encode(b"\0" * 10).decode(),
                             "../../../../../../../../etc/passwd", "", "a" * 5000, "buf%00.bin", "http://example.com/b.bin"]):
        def setup(d, fx, uri=uri):
            g = json.load(open(os.path.join(fx, "ext.gltf")))
            g["buffers"][0]["uri"] = uri
            json.dump(g, open(os.path.join(d, "scene.gltf"), "w"))
        add(Case(f"file-gltf-uri-{j}", "files", "synth",
                 ["synth", "{D}/scene.gltf", "--out", "{D}/out", "--grid", "2x2", "--size", "32x32"], setup=setup,
                 expect="fail", words=("buffer", "uri")))
    # Manifest referring to odd paths
    for j, path in enumerate(["/dev/zero", "/dev/stdin", "/proc/self/mem", "/etc", "", "nope.png", "view_1_1.png/x",
                              "../man/view_0_0.png", "/dev/null", "a" * 4000 + ".png"]):
        def setup(d, fx, path=path):
            cp("man")(d, fx)
            m = json.load(open(os.path.join(d, "man/tiltfield.json")))
            m["views"][4]["image"] = path
            json.dump(m, open(os.path.join(d, "man/tiltfield.json"), "w"))
        add(Case(f"file-man-imagepath-{j}", "files", "info", ["info", "{D}/man"], setup=setup,
                 expect="any" if j == 7 else "fail", words=("image", "view")))
        def setup2(d, fx, path=path):
            cp("man")(d, fx)
            m = json.load(open(os.path.join(d, "man/tiltfield.json")))
            m["views"][4]["depth"] = path
            json.dump(m, open(os.path.join(d, "man/tiltfield.json"), "w"))
        add(Case(f"file-man-depthpath-{j}", "files", "render", ["render", "{D}/man", "-o", "{D}/o.png", "--click", "10,10"],
                 setup=setup2, expect="fail", outputs=[("o.png", "png")], words=("depth",)))

    # ---------------- corrupt files ------------------------------------------------------------
    rng = random.Random(24)
    HOWS = ["trunc", "flip", "junk", "insert", "dup", "zero_tail"]
    for j in range(45):
        how = HOWS[j % len(HOWS)]
        seed = rng.randrange(1 << 30)
        add(Case(f"corrupt-png-view-{j}", "corrupt", "render", ["render", HCI, "-o", "{D}/o.png", "--disparity", "0"],
                 setup=chain(cp("hci"), damage_file("hci/input_Cam004.png", lambda b, s=seed, h=how: mutate(b, random.Random(s), h))),
                 outputs=[("o.png", "png")], words=("input_Cam004",)))
    for j in range(40):
        seed = rng.randrange(1 << 30)
        add(Case(f"corrupt-params-{j}", "corrupt", "render", ["render", HCI, "-o", "{D}/o.png", "--disparity", "0.3"],
                 setup=chain(cp("hci"), damage_file("hci/parameters.cfg",
                             lambda b, s=seed: mutate_text(b.decode(), random.Random(s)).encode("utf-8", "surrogatepass")
                             if s % 5 else mutate(b, random.Random(s), "flip"))),
                 outputs=[("o.png", "png")], words=("parameters.cfg",)))
    PARAM_EDITS = {
        "cams0": ("num_cams_x = 3", "num_cams_x = 0"), "camsbig": ("num_cams_x = 3", "num_cams_x = 4294967297"),
        "camsneg": ("num_cams_y = 3", "num_cams_y = -3"), "cams4": ("num_cams_x = 3", "num_cams_x = 4"),
        "cams1": ("num_cams_x = 3", "num_cams_x = 1"), "res0": ("image_resolution_x_px = 48", "image_resolution_x_px = 0"),
        "resbig": ("image_resolution_x_px = 48", "image_resolution_x_px = 100000"),
        "resmismatch": ("image_resolution_x_px = 48", "image_resolution_x_px = 64"),
        "focal0": ("focal_length_mm = 43.199999999999996", "focal_length_mm = 0"),
        "focalinf": ("focal_length_mm = 43.199999999999996", "focal_length_mm = inf"),
        "sensor0": ("sensor_size_mm = 36.0", "sensor_size_mm = 0"),
        "baseline0": ("baseline_mm = 20.0", "baseline_mm = 0"), "baselineneg": ("baseline_mm = 20.0", "baseline_mm = -20"),
        "focus0": ("focus_distance_m = 2.5", "focus_distance_m = 0"), "focusnan": ("focus_distance_m = 2.5", "focus_distance_m = NaN"),
        "focus1e308": ("focus_distance_m = 2.5", "focus_distance_m = 1e308"),
        "nosection": ("[extrinsics]", ""), "dupkey": ("num_cams_y = 3", "num_cams_y = 3\nnum_cams_y = 5"),
        "dispminmax": ("[meta]", "[meta]\ndisp_min = 1e308\ndisp_max = -1e308"),
        "dispnan": ("[meta]", "[meta]\ndisp_min = nan\ndisp_max = nan"),
        "dispinf": ("[meta]", "[meta]\ndisp_min = -inf\ndisp_max = inf"),
        "dispeq": ("[meta]", "[meta]\ndisp_min = 0.5\ndisp_max = 0.5"),
        "hugeline": ("[meta]", "[meta]\nx = " + "9" * 200000),
        "nokeys": None,
    }
    for name, edit in PARAM_EDITS.items():
        def setup(d, fx, edit=edit):
            cp("hci")(d, fx)
            p = os.path.join(d, "hci/parameters.cfg")
            t = open(p).read()
            t = t.replace(*edit) if edit else "[intrinsics]\n"
            open(p, "w").write(t)
        for cmd, argv, outs in [("render", ["render", HCI, "-o", "{D}/o.png", "--disparity", "0.3"], [("o.png", "png")]),
                                ("depth", ["depth", HCI, "-o", "{D}/d.pfm"], [("d.pfm", "pfm")])]:
            add(Case(f"corrupt-params-edit-{name}-{cmd}", "corrupt", cmd, argv, setup=setup, outputs=outs,
                     words=("parameters.cfg",)))
    for j in range(45):
        seed = rng.randrange(1 << 30)
        textual = j % 3 != 2
        add(Case(f"corrupt-manifest-{j}", "corrupt", "render", ["render", "{D}/man", "-o", "{D}/o.png", "--disparity", "0"],
                 setup=chain(cp("man"), damage_file("man/tiltfield.json",
                             (lambda b, s=seed: mutate_text(b.decode(), random.Random(s)).encode("utf-8", "surrogatepass"))
                             if textual else (lambda b, s=seed: mutate(b, random.Random(s), HOWS[s % 6])))),
                 outputs=[("o.png", "png")], words=("tiltfield.json",)))
    MAN_EDITS = {
        "Rnan": lambda m: m["views"][0].__setitem__("R", [[float("nan")] * 3] * 3),
        "Rscaled": lambda m: m["views"][0].__setitem__("R", [[2, 0, 0], [0, 2, 0], [0, 0, 2]]),
        "Rrefl": lambda m: m["views"][0].__setitem__("R", [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]),
        "K0": lambda m: m["views"][0].__setitem__("K", [[0, 0, 0], [0, 0, 0], [0, 0, 1]]),
        "Khuge": lambda m: m["views"][0].__setitem__("K", [[1e308, 0, 1e308], [0, 1e308, 0], [0, 0, 1]]),
        "Kbadrow": lambda m: m["views"][0].__setitem__("K", [[40, 0, 14], [0, 40, 14], [1, 1, 1]]),
        "tcentre": lambda m: m["views"][0].__setitem__("centre", [0, 0, 0]),
        "tnone": lambda m: m["views"][0].pop("t", None),
        "dupgrid": lambda m: m["views"][1].__setitem__("grid", {"s": 0, "t": 0}),
        "gridneg": lambda m: m["views"][1].__setitem__("grid", {"s": -1, "t": 0}),
        "gridhuge": lambda m: m["views"][1].__setitem__("grid", {"s": 18446744073709551615, "t": 0}),
        "gridfloat": lambda m: m["views"][1].__setitem__("grid", {"s": 0.5, "t": 0}),
        "gridbig": lambda m: m["views"][1].__setitem__("grid", {"s": 100000, "t": 100000}),
        "unknownkey": lambda m: m.__setitem__("colour", 1),
        "version2": lambda m: m.__setitem__("version", 2),
        "noviews": lambda m: m.__setitem__("views", []),
        "oneview": lambda m: m.__setitem__("views", m["views"][:1]),
        "drop": lambda m: m["views"].pop(4),
        "rigzero": lambda m: m.__setitem__("rig", {"focal_px": 0, "baseline": 0, "focus_distance": 0}),
        "rignan": lambda m: m.__setitem__("rig", {"focal_px": 40, "baseline": 1e308, "focus_distance": 1e-308}),
        "string": lambda m: m.__setitem__("views", "x"),
        "many": lambda m: m.__setitem__("views", m["views"] * 2000),
        "mixedsize": None,
    }
    for name, fn in MAN_EDITS.items():
        def setup(d, fx, fn=fn, name=name):
            cp("man")(d, fx)
            p = os.path.join(d, "man/tiltfield.json")
            m = json.load(open(p))
            if fn:
                fn(m)
            else:
                open(os.path.join(d, "man/view_2_2.png"), "wb").write(png_bytes(40, 32))
            open(p, "w").write(json.dumps(m).replace("NaN", "NaN"))
        add(Case(f"corrupt-manifest-edit-{name}", "corrupt", "render",
                 ["render", "{D}/man", "-o", "{D}/o.png", "--disparity", "0"], setup=setup,
                 outputs=[("o.png", "png")], words=("tiltfield.json", "view")))
    for j, txt in enumerate(["", "{", "[]", "null", "1e999999", "\ufeff{}", "{\"version\":1}", "[" * 100000 + "]" * 100000,
                             "{\"version\":1,\"views\":[{}]}", "\0\0\0\0", "{\"version\":1,\"version\":1,\"views\":[]}",
                             "{\"version\": 18446744073709551616, \"views\": []}"]):
        add(Case(f"corrupt-manifest-lit-{j}", "corrupt", "info", ["info", "{D}/lf.json"], setup=write("lf.json", txt),
                 expect="fail", words=("lf.json",)))
    # PFM maps (HCI ground truth used by --click/cloud/antialias; --score)
    PFMS = {
        "hdr-garbage": b"XX\n48 48\n-1\n" + b"\0" * 9216,
        "hdr-huge": pfm_bytes(48, 48, header=b"Pf\n4294967295 4294967295\n-1\n"),
        "hdr-neg": pfm_bytes(48, 48, header=b"Pf\n-48 48\n-1\n"),
        "hdr-zero": b"Pf\n0 0\n-1\n",
        "hdr-scale0": pfm_bytes(48, 48, scale=0.0),
        "hdr-scalenan": pfm_bytes(48, 48, header=b"Pf\n48 48\nnan\n"),
        "hdr-color": pfm_bytes(48, 48, header=b"PF\n48 48\n-1\n"),
        "short": pfm_bytes(48, 48)[:5000],
        "wrongsize": pfm_bytes(32, 32),
        "allnan": pfm_bytes(48, 48, np.full((48, 48), np.nan)),
        "allinf": pfm_bytes(48, 48, np.full((48, 48), np.inf)),
        "huge-values": pfm_bytes(48, 48, np.full((48, 48), 3e38)),
        "bigendian": b"Pf\n48 48\n1.0\n" + np.full((48, 48), 0.1, dtype=">f4").tobytes(),
        "trailing": pfm_bytes(48, 48) + b"\0" * 1000,
        "overflow-dims": pfm_bytes(48, 48, header=b"Pf\n18446744073709551615 2\n-1\n"),
    }
    for name, data in PFMS.items():
        add(Case(f"corrupt-gt-pfm-{name}-click", "corrupt", "render", ["render", HCI, "-o", "{D}/o.png", "--click", "24,24"],
                 setup=chain(cp("hci"), write("hci/gt_disp_lowres.pfm", data), write("hci/gt_depth_lowres.pfm", data)),
                 outputs=[("o.png", "png")], words=("gt_", "pfm", "depth")))
        add(Case(f"corrupt-gt-pfm-{name}-score", "corrupt", "depth", ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/gt.pfm"],
                 setup=chain(cp("hci"), write("gt.pfm", data)), outputs=[("d.pfm", "pfm")], words=("gt.pfm",),
                 post=score_sane))
        add(Case(f"corrupt-man-pfm-{name}", "corrupt", "cloud", ["cloud", "{D}/man", "-o", "{D}/c.ply"],
                 setup=chain(cp("man"), write("man/depth_1_1.pfm", data), write("man/disparity_1_1.pfm", data)),
                 outputs=[("c.ply", "ply")], words=("depth_1_1", "disparity_1_1", "pfm")))
    # EXR depth in a manifest (the synth normals EXR as a stand-in and damaged versions)
    for j in range(12):
        seed = rng.randrange(1 << 30)
        def setup(d, fx, seed=seed, j=j):
            cp("man")(d, fx)
            src = open(os.path.join(d, "man/gt_normals_centre.exr"), "rb").read()
            data = src if j == 0 else mutate(src, random.Random(seed), HOWS[j % 6])
            open(os.path.join(d, "man/d.exr"), "wb").write(data)
            p = os.path.join(d, "man/tiltfield.json")
            m = json.load(open(p))
            m["views"][4].pop("depth", None)
            m["views"][4].pop("disparity", None)
            m["views"][4]["depth"] = "d.exr"
            json.dump(m, open(p, "w"))
        add(Case(f"corrupt-man-exr-{j}", "corrupt", "cloud", ["cloud", "{D}/man", "-o", "{D}/c.ply"], setup=setup,
                 outputs=[("c.ply", "ply")], words=("d.exr", "exr")))
    # glTF / glb
    for j in range(35):
        seed = rng.randrange(1 << 30)
        src = "example.glb" if j % 2 else "ext.gltf"
        fn = (lambda b, s=seed: mutate(b, random.Random(s), HOWS[s % 6])) if src.endswith("glb") or j % 4 == 0 else \
             (lambda b, s=seed: mutate_text(b.decode(), random.Random(s)).encode("utf-8", "surrogatepass"))
        add(Case(f"corrupt-{src.split('.')[1]}-{j}", "corrupt", "synth",
                 ["synth", "{D}/" + src, "--out", "{D}/out", "--grid", "2x2", "--size", "32x32"],
                 setup=chain(cp(src), cp("example.bin") if src.endswith("gltf") else None, damage_file(src, fn)),
                 outputs=[("out", "dir_hci")], words=(src, "gltf", "glb"), followup=["info", "{D}/out"]))
    GLTF_EDITS = {
        "accessor-count": lambda g: g["accessors"][0].__setitem__("count", 18446744073709551615),
        "accessor-count-big": lambda g: g["accessors"][0].__setitem__("count", 4294967295),
        "accessor-offset": lambda g: g["accessors"][0].__setitem__("byteOffset", 4294967295),
        "accessor-offset-u64": lambda g: g["accessors"][0].__setitem__("byteOffset", 18446744073709551615),
        "accessor-count-2^61": lambda g: g["accessors"][0].__setitem__("count", 2 ** 61),
        "accessor-count-2^63": lambda g: g["accessors"][0].__setitem__("count", 2 ** 63),
        "accessor-count-u64/12": lambda g: g["accessors"][0].__setitem__("count", 2 ** 64 // 12 + 1),
        "accessor-count-2^32x3": lambda g: g["accessors"][0].__setitem__("count", 3 * 2 ** 32),
        "index-count-u64": lambda g: [a.__setitem__("count", 18446744073709551615) for a in g["accessors"] if a.get("componentType") in (5121, 5123, 5125)],
        "view-offset-u64": lambda g: g["bufferViews"][0].__setitem__("byteOffset", 18446744073709551615),
        "buffer-len-u64": lambda g: g["buffers"][0].__setitem__("byteLength", 18446744073709551615),
        "view-length": lambda g: g["bufferViews"][0].__setitem__("byteLength", 18446744073709551615),
        "view-stride": lambda g: g["bufferViews"][0].__setitem__("byteStride", 255),
        "buffer-len": lambda g: g["buffers"][0].__setitem__("byteLength", 1),
        "node-cycle": lambda g: g["nodes"][0].__setitem__("children", [0]),
        "node-bad-mesh": lambda g: g["nodes"][0].__setitem__("mesh", 99),
        "scene-bad": lambda g: g.__setitem__("scene", 99),
        "matrix-nan": lambda g: g["nodes"][0].__setitem__("matrix", [float("nan")] * 16),
        "scale0": lambda g: g["nodes"][0].__setitem__("scale", [0, 0, 0]),
        "scalehuge": lambda g: g["nodes"][0].__setitem__("scale", [1e38, 1e38, 1e38]),
        "no-meshes": lambda g: g.pop("meshes", None),
        "no-scenes": lambda g: g.pop("scenes", None),
        "camera-yfov0": lambda g: [c.get("perspective", {}).__setitem__("yfov", 0) for c in g.get("cameras", [])],
        "camera-znear-neg": lambda g: [c.get("perspective", {}).__setitem__("znear", -1) for c in g.get("cameras", [])],
        "image-uri": lambda g: g.__setitem__("images", [{"uri": "/dev/zero"}]),
        "deep-nodes": lambda g: g.__setitem__("nodes", [{"children": [i + 1]} for i in range(5000)] + [{}]),
        "primitive-mode": lambda g: [p.__setitem__("mode", 0) for m in g.get("meshes", []) for p in m["primitives"]],
        "indices-oob": None,
    }
    for name, fn in GLTF_EDITS.items():
        def setup(d, fx, fn=fn):
            cp("example.bin")(d, fx)
            g = json.load(open(os.path.join(fx, "ext.gltf")))
            if fn:
                fn(g)
            else:
                # indices pointing far past the vertices: rewrite the index buffer bytes
                b = bytearray(open(os.path.join(d, "example.bin"), "rb").read())
                acc = [a for a in g["accessors"] if a.get("componentType") in (5123, 5125)]
                if acc:
                    bv = g["bufferViews"][acc[0]["bufferView"]]
                    off = bv.get("byteOffset", 0) + acc[0].get("byteOffset", 0)
                    b[off:off + 4] = b"\xff\xff\xff\xff"
                open(os.path.join(d, "example.bin"), "wb").write(bytes(b))
            json.dump(g, open(os.path.join(d, "scene.gltf"), "w"))
        add(Case(f"corrupt-gltf-edit-{name.replace('/', 'd')}", "corrupt", "synth",
                 ["synth", "{D}/scene.gltf", "--out", "{D}/out", "--grid", "2x2", "--size", "32x32"], setup=setup,
                 outputs=[("out", "dir_hci")], words=("scene.gltf", "gltf"), followup=["info", "{D}/out"]))
    # Technicolor cameras_parameters.txt
    for j in range(35):
        seed = rng.randrange(1 << 30)
        add(Case(f"corrupt-video-params-{j}", "corrupt", "render",
                 ["render", "{D}/video", "-o", "{D}/o.png", "--focus", "2"],
                 setup=chain(cp("video"), damage_file("video/cameras_parameters.txt",
                             lambda b, s=seed: mutate_text(b.decode(), random.Random(s)).encode("utf-8", "surrogatepass"))),
                 outputs=[("o.png", "png")], words=("cameras_parameters",)))
    VIDEO_EDITS = {
        "q0": ("1 0 0 0 -0.1", "0 0 0 0 -0.1"), "qoff": ("1 0 0 0 -0.1", "2 0 0 0 -0.1"),
        "f0": ("28 15.5", "0 15.5"), "fneg": ("28 15.5", "-28 15.5"), "ar0": ("11.5 1 0", "11.5 0 0"),
        "values11": ("1 0 0 0 -0.1 0 0", "1 0 0 0 -0.1 0"), "values14": ("11.5 1 0 1", "11.5 1 0 0 0 1"),
        "fold": ("11.5 1 0 1", "11.5 1 0 -100 100 1"), "samecentre": ("-0.1 0 0", "0 0 0"),
        "cam-nan": ("-0.2 0 0", "nan 0 0"), "tinf": ("-0.2 0 0", "1e308 0 0"),
        "header-only": None,
    }
    for name, edit in VIDEO_EDITS.items():
        def setup(d, fx, edit=edit):
            cp("video")(d, fx)
            p = os.path.join(d, "video/cameras_parameters.txt")
            t = open(p).read()
            t = t.replace(edit[0], edit[1], 1) if edit else t.split("\n")[0] + "\n"
            open(p, "w").write(t)
        add(Case(f"corrupt-video-edit-{name}", "corrupt", "render", ["render", "{D}/video", "-o", "{D}/o.png", "--focus", "2"],
                 setup=setup, outputs=[("o.png", "png")], words=("cameras_parameters", "camera")))
    # ---------------- mismatched and missing views --------------------------------------------
    MM = {
        "hci-missing": chain(cp("hci"), remove("hci/input_Cam004.png")),
        "hci-missing-last": chain(cp("hci"), remove("hci/input_Cam008.png")),
        "hci-extra": chain(cp("hci"), cp("hci/input_Cam000.png", "hci/input_Cam009.png")),
        "hci-extra-gap": chain(cp("hci"), cp("hci/input_Cam000.png", "hci/input_Cam099.png")),
        "hci-size": chain(cp("hci"), write("hci/input_Cam004.png", png_bytes(40, 48))),
        "hci-size-all": chain(cp("hci"), *[write(f"hci/input_Cam{i:03d}.png", png_bytes(64, 64, seed=i)) for i in range(9)]),
        "hci-grey": chain(cp("hci"), write("hci/input_Cam004.png", png_bytes(48, 48, "L"))),
        "hci-rgba": chain(cp("hci"), write("hci/input_Cam004.png", png_bytes(48, 48, "RGBA"))),
        "hci-16bit": chain(cp("hci"), write("hci/input_Cam004.png", png_bytes(48, 48, bits=16))),
        "hci-palette": chain(cp("hci"), write("hci/input_Cam004.png", png_bytes(48, 48, "P"))),
        "hci-1bit": chain(cp("hci"), write("hci/input_Cam004.png", png_bytes(48, 48, "1"))),
        "hci-huge-header": chain(cp("hci"), write("hci/input_Cam004.png", png_header_only(100000, 100000))),
        "hci-huge-header2": chain(cp("hci"), write("hci/input_Cam004.png", png_header_only(4294967295, 1))),
        "hci-jpg-as-png": chain(cp("hci"), write("hci/input_Cam004.png", b"\xff\xd8\xff\xe0" + b"\0" * 100)),
        "hci-black": chain(cp("hci"), *[write(f"hci/input_Cam{i:03d}.png", png_bytes(48, 48, "L", seed=i)
                                              if False else _black(48, 48)) for i in range(9)]),
        "hci-all-black-but-centre": chain(cp("hci"), *[write(f"hci/input_Cam{i:03d}.png", _black(48, 48)) for i in range(9) if i != 4]),
        "hci-empty-folder": lambda d, fx: os.makedirs(os.path.join(d, "hci")),
        "hci-only-params": chain(cp("hci"), *[remove(f"hci/input_Cam{i:03d}.png") for i in range(9)]),
        "hci-1x1": chain(cp("hci"), lambda d, fx: _sub(d, "hci/parameters.cfg", [("num_cams_x = 3", "num_cams_x = 1"), ("num_cams_y = 3", "num_cams_y = 1")])),
        "hci-3x1": chain(cp("hci"), lambda d, fx: _sub(d, "hci/parameters.cfg", [("num_cams_y = 3", "num_cams_y = 1")])),
        "grid-missing": chain(cp("grid"), remove("grid/view_01_01.png")),
        "grid-dup": chain(cp("grid"), cp("grid/view_01_01.png", "grid/view_1_1.png")),
        "grid-size": chain(cp("grid"), write("grid/view_01_01.png", png_bytes(40, 40))),
        "grid-one-row": chain(cp("grid"), *[remove(f"grid/view_{t:02d}_{s:02d}.png") for t in (1, 2) for s in range(3)]),
        "grid-one-view": chain(cp("grid"), *[remove(f"grid/view_{t:02d}_{s:02d}.png") for t in range(3) for s in range(3) if (t, s) != (0, 0)]),
        "grid-two-sets": chain(cp("grid"), *[cp(f"grid/view_{t:02d}_{s:02d}.png", f"grid/img-{t}-{s}.png") for t in range(3) for s in range(3)]),
        "grid-subfolders": chain(cp("grid", "grid/a"), cp("grid", "grid/b")),
        "grid-hidden": chain(cp("grid"), write("grid/._view_03_03.png", b"junk")),
        "grid-bignum": chain(cp("grid"), lambda d, fx: [os.rename(os.path.join(d, f"grid/view_{t:02d}_{s:02d}.png"),
                             os.path.join(d, f"grid/view_{t + 18446744073709551613}_{s}.png")) for t in range(3) for s in range(3)]),
        "grid-hugenum": chain(cp("grid"), lambda d, fx: [os.rename(os.path.join(d, f"grid/view_{t:02d}_{s:02d}.png"),
                             os.path.join(d, f"grid/view_{'9' * 40}{t}_{s}.png")) for t in range(3) for s in range(3)]),
        "grid-nonimage": chain(cp("grid"), write("grid/view_01_03.png", b"not a png")),
        "video-missing-cam": chain(cp("video"), remove("video/S_undist_00001_02.png")),
        "video-extra-cam": chain(cp("video"), cp("video/S_undist_00001_02.png", "video/S_undist_00001_07.png")),
        "video-two-scenes": chain(cp("video"), cp("video/S_undist_00001_02.png", "video/T_undist_00001_02.png")),
        "video-size": chain(cp("video"), write("video/S_undist_00002_01.png", png_bytes(30, 24))),
        "video-noframes": chain(cp("video"), lambda d, fx: [os.remove(p) for p in _glob(d, "video", ".png")]),
        "video-badname": chain(cp("video"), write("video/S_undist_x_01.png", png_bytes(32, 24))),
        "video-hugeframe": chain(cp("video"), cp("video/S_undist_00001_00.png", "video/S_undist_99999999999999999999999_00.png")),
        "video-sub-two": chain(cp("video"), lambda d, fx: [os.makedirs(os.path.join(d, "video/a")), os.makedirs(os.path.join(d, "video/b")),
                               [shutil.move(p, os.path.join(d, "video/a")) for p in _glob(d, "video", ".png")],
                               [shutil.copy(p, os.path.join(d, "video/b")) for p in _glob(d, "video/a", ".png")]]),
    }
    for name, setup in MM.items():
        lf = "{D}/" + name.split("-")[0]
        for cmd, argv, outs in [("info", ["info", lf], []),
                                ("render", ["render", lf, "-o", "{D}/o.png", "--focus", "2"], [("o.png", "png")]),
                                ("depth", ["depth", lf, "-o", "{D}/d.pfm"], [("d.pfm", "pfm")])]:
            add(Case(f"mismatch-{name}-{cmd}", "mismatch", cmd, argv, setup=setup, outputs=outs,
                     words=("view", "cam", "grid", "frame", "size", "png", "black", "missing")))

    # tiny and extreme view sizes, single-view and single-row light fields
    for (w, h) in [(1, 1), (2, 1), (1, 64), (3, 3), (4096, 1), (1, 4096), (5, 7)]:
        def setup(d, fx, w=w, h=h):
            os.makedirs(os.path.join(d, "tiny"))
            for t in range(3):
                for s_ in range(3):
                    arr = np.random.default_rng(t * 3 + s_).integers(0, 255, (h, w, 3), dtype=np.uint8)
                    Image.fromarray(arr).save(os.path.join(d, f"tiny/view_{t}_{s_}.png"))
        for cmd, argv, outs in [("render", ["render", "{D}/tiny", "-o", "{D}/o.png", "--disparity", "0.5"], [("o.png", "png")]),
                                ("render", ["render", "{D}/tiny", "-o", "{D}/o.png", "--focus", "1", "--tilt", "30", "--antialias", "on"], [("o.png", "png")]),
                                ("render", ["render", "{D}/tiny", "-o", "{D}/o.png", "--click", "0,0"], [("o.png", "png")]),
                                ("depth", ["depth", "{D}/tiny", "-o", "{D}/d.pfm", "--confidence", "{D}/c.png"], [("d.pfm", "pfm"), ("c.png", "png")]),
                                ("cloud", ["cloud", "{D}/tiny", "-o", "{D}/c.ply", "--cameras", "--focus", "1"], [("c.ply", "ply")]),
                                ("bench", ["bench", "{D}/tiny", "--quick", "--no-scaling", "--out", "{D}/b"], [("b/bench.json", "json")])]:
            add(Case(f"mismatch-tiny-{w}x{h}-{cmd}-{argv[4].lstrip('-')}", "mismatch", cmd, argv, setup=setup, outputs=outs,
                     words=("pixel", "view", "depth", "size", "small")))
    SINGLE = {
        "hci-1x1": chain(cp("hci"), lambda d, fx: _sub(d, "hci/parameters.cfg", [("num_cams_x = 3", "num_cams_x = 1"), ("num_cams_y = 3", "num_cams_y = 1")])),
        "hci-1x3": chain(cp("hci"), lambda d, fx: _sub(d, "hci/parameters.cfg", [("num_cams_x = 3", "num_cams_x = 1")])),
        "man-1": chain(cp("man"), lambda d, fx: _keep_views(os.path.join(d, "man/tiltfield.json"), [4])),
        "man-2": chain(cp("man"), lambda d, fx: _keep_views(os.path.join(d, "man/tiltfield.json"), [0, 1])),
        "grid-1": chain(cp("grid"), *[remove(f"grid/view_{t:02d}_{s:02d}.png") for t in range(3) for s in range(3) if (t, s) != (1, 1)]),
        "video-1cam": lambda d, fx: make_video(os.path.join(d, "video"), cams=1),
        "video-2cam": lambda d, fx: make_video(os.path.join(d, "video"), cams=2),
    }
    for name, setup in SINGLE.items():
        lf = "{D}/" + name.split("-")[0]
        for cmd, argv, outs in [("info", ["info", lf, "--json"], []),
                                ("render", ["render", lf, "-o", "{D}/o.png", "--disparity", "0"], [("o.png", "png")]),
                                ("render", ["render", lf, "-o", "{D}/o.png", "--focus", "2", "--antialias", "on"], [("o.png", "png")]),
                                ("render", ["render", lf, "-o", "{D}/o.exr", "--focus", "2", "--strategy", "compute", "--view", "0.5,0"], [("o.exr", "exr")]),
                                ("depth", ["depth", lf, "-o", "{D}/d.pfm"], [("d.pfm", "pfm")]),
                                ("cloud", ["cloud", lf, "-o", "{D}/c.ply"], [("c.ply", "ply")]),
                                ("bench", ["bench", lf, "--quick", "--no-scaling", "--focus", "2", "--out", "{D}/b"], [("b/bench.json", "json")])]:
            add(Case(f"mismatch-single-{name}-{cmd}-{'-'.join(a.lstrip('-') for a in argv[4:7])}", "mismatch", cmd, argv,
                     setup=setup, outputs=outs, words=("view", "grid", "camera", "one", "single")))

    # ---------------- outputs -------------------------------------------------------------------
    OUTKINDS = {
        "devfull": lambda d: "/dev/full",
        "folder": lambda d: (os.makedirs(os.path.join(d, "outdir.png")), os.path.join(d, "outdir.png"))[-1],
        "underfile": lambda d: (open(os.path.join(d, "afile"), "w").close(), os.path.join(d, "afile/x.png"))[-1],
        "dangling": lambda d: (os.symlink(os.path.join(d, "target/t.png"), os.path.join(d, "dl.png")), os.path.join(d, "dl.png"))[-1],
        "link-outside": lambda d: (os.makedirs(os.path.join(d, "outside")), open(os.path.join(d, "outside/victim.png"), "w").write("keep"),
                                   os.symlink(os.path.join(d, "outside/victim.png"), os.path.join(d, "ln.png")), os.path.join(d, "ln.png"))[-1],
        "fifo": lambda d: (os.mkfifo(os.path.join(d, "p.png")), os.path.join(d, "p.png"))[-1],
        "devnull": lambda d: "/dev/null",
        "devfull-link": lambda d: (os.symlink("/dev/full", os.path.join(d, "full.png")), os.path.join(d, "full.png"))[-1],
        "devnull-link": lambda d: (os.symlink("/dev/null", os.path.join(d, "null.png")), os.path.join(d, "null.png"))[-1],
        "empty": lambda d: "",
        "longname": lambda d: os.path.join(d, "a" * 300 + ".png"),
        "newline": lambda d: os.path.join(d, "a\nb.png"),
        "nested-new": lambda d: os.path.join(d, "x/y/z/o.png"),
        "dot": lambda d: ".",
        "proc": lambda d: "/proc/self/x.png",
        "stdout": lambda d: "-",
    }
    OUTCMDS = [
        ("render", lambda o: ["render", HCI, "-o", o, "--disparity", "0"], ".png", "png"),
        ("render-exr", lambda o: ["render", HCI, "-o", o, "--disparity", "0"], ".exr", "exr"),
        ("depth", lambda o: ["depth", HCI, "-o", o], ".pfm", "pfm"),
        ("depth-conf", lambda o: ["depth", HCI, "-o", "{D}/d.pfm", "--confidence", o], ".png", "png"),
        ("cloud", lambda o: ["cloud", HCI, "-o", o], ".ply", "ply"),
        ("synth", lambda o: ["synth", "builtin:planes", "--out", o[:-4] if o.endswith(".png") else o, "--grid", "2x2", "--size", "32x32"], ".png", "dir_hci"),
        ("demo", lambda o: ["demo", "--scene", "planes", "-o", o[:-4] if o.endswith(".png") else o], ".png", "demojson"),
        ("bench", lambda o: ["bench", HCI, "--quick", "--no-scaling", "--disparity", "0", "--out", o[:-4] if o.endswith(".png") else o], ".png", "benchjson"),
        ("depth-set", lambda o: ["depth-set", "--grid", "3", "--size", "48", "--scenes", "planes", "--variants", "sweep", "--markdown", o[:-4] + ".md" if o.endswith(".png") else o], ".md", "nonempty"),
        ("frames", lambda o: ["render", "{D}/video", "--frames", "1..2", "--disparity", "0", "-o", o[:-4] + "_{frame}.png" if o.endswith(".png") else o], ".png", "png"),
    ]
    for cname, mk, ext, okind in OUTCMDS:
        for kname, kf in OUTKINDS.items():
            def setup(d, fx, kf=kf, ext=ext, cname=cname):
                cp("hci")(d, fx)
                if cname == "frames":
                    cp("video")(d, fx)
                o = kf(d)
                if ext != ".png" and o.endswith(".png") and not os.path.lexists(o):
                    o = o[:-4] + ext
                if ext != ".png" and o.endswith(".png") and os.path.lexists(o):
                    # make the odd thing again under the right extension
                    p2 = o[:-4] + ext
                    if os.path.islink(o):
                        os.symlink(os.readlink(o), p2)
                    elif os.path.isdir(o):
                        os.makedirs(p2)
                    else:
                        os.mkfifo(p2) if _is_fifo(o) else None
                    o = p2
                open(os.path.join(d, ".outpath"), "w").write(o)
            argv = mk("{OUT}")
            add(Case(f"out-{cname}-{kname}", "outputs", argv[0], argv, setup=setup,
                     outputs=[("{OUT}", okind)],
                     expect="any" if kname in ("nested-new", "longname", "newline", "stdout")
                     or (cname in ("synth", "demo", "bench") and kname in ("folder", "dot")) else "fail",
                     words=("output", "write", "writ", "-o", "folder", "directory", "device", "link", "fifo", "exist", "name", "extension"),
                     post=out_post))
    # failing runs with an output in folders that do not exist yet: nothing may be left behind
    for cname, argv in [("render", ["render", "{D}/empty", "-o", "{D}/x/y/o.png", "--disparity", "0"]),
                        ("render-bad", ["render", HCI, "-o", "{D}/x/y/o.png", "--disparity", "NaN"]),
                        ("render-noreach", ["render", "{D}/video", "-o", "{D}/x/y/o.png", "--focus", "0.001"]),
                        ("frames-noreach", ["render", "{D}/video", "--frames", "1..3", "-o", "{D}/x/y/o_{frame}.png", "--focus", "0.001"]),
                        ("depth", ["depth", "{D}/empty", "-o", "{D}/x/y/d.pfm"]),
                        ("depth-conf", ["depth", "{D}/empty", "-o", "{D}/d.pfm", "--confidence", "{D}/x/y/c.png"]),
                        ("depth-score", ["depth", HCI, "-o", "{D}/x/y/d.pfm", "--score", "{D}/missing.pfm"]),
                        ("cloud", ["cloud", "{D}/empty", "-o", "{D}/x/y/c.ply"]),
                        ("cloud-click", ["cloud", HCI, "-o", "{D}/x/y/c.ply", "--click", "99999,0"]),
                        ("synth", ["synth", "builtin:nope", "--out", "{D}/x/y/s"]),
                        ("synth-bad", ["synth", "builtin:planes", "--out", "{D}/x/y/s", "--grid", "0x0"]),
                        ("demo", ["demo", "--scene", "nope", "-o", "{D}/x/y/demo"]),
                        ("bench", ["bench", "{D}/empty", "--quick", "--out", "{D}/x/y/b"]),
                        ("bench-variants", ["bench", HCI, "--quick", "--out", "{D}/x/y/b", "--variants", "bogus"]),
                        ("depth-set", ["depth-set", "--scenes", "nope", "--markdown", "{D}/x/y/t.md"]),
                        ("view", ["view", HCI, "--disparity", "0", "--screenshot-prefix", "{D}/x/y/shot"])]:
        add(Case(f"out-leftover-{cname}", "outputs", argv[0], argv,
                 setup=chain(cp("hci"), cp("video"), lambda d, fx: os.makedirs(os.path.join(d, "empty"))),
                 expect="fail", post=lambda d, fx, rc, out, err: ("leftover", "failed run left x/ behind")
                 if rc != 0 and os.path.lexists(os.path.join(d, "x")) else None))
    # --frames: a later frame's output is a folder / a link: refused before the first is written
    for kind in ("dir", "dangling", "fifo", "devnull"):
        add(Case(f"out-frames-later-{kind}", "outputs", "render",
                 ["render", "{D}/video", "--frames", "1..3", "--disparity", "0", "-o", "{D}/f_{frame}.png"],
                 setup=chain(cp("video"), special("f_3.png", kind)), expect="fail", words=("f_3.png",),
                 post=lambda d, fx, rc, out, err: ("leftover", "f_1.png written before the refusal")
                 if rc != 0 and os.path.lexists(os.path.join(d, "f_1.png")) else None))
    # wrong extensions
    for j, name in enumerate(["o.jpg", "o.PNG", "o", "o.png.tmp", "o.exr.png", ".png", "o.pfm", "o.ply"]):
        for cmd, mk in [("render", lambda o: ["render", HCI, "-o", o, "--disparity", "0"]),
                        ("depth", lambda o: ["depth", HCI, "-o", o]), ("cloud", lambda o: ["cloud", HCI, "-o", o])]:
            add(Case(f"out-ext-{cmd}-{j}", "outputs", cmd, mk("{D}/" + name), setup=cp("hci"),
                     outputs=[(name, "any_output")], words=("extension", "must end", "output", ".png", ".pfm", ".ply")))

    # ---------------- viewer scripts ------------------------------------------------------------
    SCRIPTS = {
        "unknown": "frobnicate 3\nquit\n", "hugecount": "key UP 10000\nquit\n", "u64count": "key UP 18446744073709551615\n",
        "negcount": "key UP -1\n", "bom": "\ufeffwait 0\nquit\n", "bom-twice": "\ufeff\ufeffquit\n",
        "binary": bytes(range(256)) * 4, "nul": "quit\0\n", "wait-nan": "wait NaN\n", "wait-inf": "wait inf\n",
        "wait-neg": "wait -1\n", "wait-hour": "wait 3600\nwait 1\n", "wait-1e308": "wait 1e308\n",
        "many-keys": "key UP 500\n" * 5, "click-out": "click refocus 100000 100000\n", "click-nan": "click refocus NaN 0\n",
        "click-neg": "click refocus -1 -1\n", "drag-huge": "drag scene 0 0 1e308 1e308\n", "scroll-huge": "scroll scene 1e308\n",
        "scroll-nan": "scroll refocus NaN\n", "resize-0": "resize 0 0\n", "resize-huge": "resize 100000 100000\n",
        "resize-u64": "resize 18446744073709551615 1\n", "screenshot-devfull": "screenshot /dev/full\n",
        "screenshot-dir": "screenshot /\n", "screenshot-under-file": "screenshot {D}/afile/x\n",
        "screenshot-proc": "screenshot /proc/self/x\n", "screenshot-empty": "screenshot\n",
        "key-unknown": "key NOPE\n", "key-shift-junk": "key shift+shift+UP\n", "long-line": "wait " + "0" * 1000000 + "\n",
        "many-lines": "wait-converged\n" * 200000, "crlf": "wait 0\r\nquit\r\n", "latin1": "wait 0 # \xe9\n".encode("latin-1"),
        "utf16": "quit\n".encode("utf-16"), "comment-only": "# nothing\n", "empty": "", "tabs": "key\tUP\t3\nquit\n",
        "trailing-junk": "quit now please\n", "click-scene-out": "click scene -5 99999\n",
        "shift-click-3": "shift-click refocus 1 1\nshift-click refocus 1 1\nshift-click refocus 1 1\nquit\n",
    }
    for name, text in SCRIPTS.items():
        def setup(d, fx, text=text):
            cp("hci")(d, fx)
            open(os.path.join(d, "afile"), "w").close()
            t = text.replace("{D}", d) if isinstance(text, str) else text
            data = t.encode("utf-8", "surrogatepass") if isinstance(t, str) else t
            open(os.path.join(d, "s.txt"), "wb").write(data)
        add(Case(f"script-{name}", "scripts", "view", ["view", HCI, "--disparity", "0", "--script", "{D}/s.txt"],
                 setup=setup, expect="fail", words=("line", "script", "display", "s.txt"), post=no_dev_files))
    # a few under a virtual X server, kept short
    XV = {
        "x-ok": ("wait-converged\nscreenshot {D}/shot\nquit\n", [("shot_refocus.png", "png"), ("shot.json", "json")]),
        "x-keys": ("key UP 3\nkey shift+LEFT 2\nwait-converged\nscreenshot {D}/k\nquit\n", [("k_refocus.png", "png")]),
        "x-click": ("click refocus 24 24\nwait-converged\nscreenshot {D}/c\nquit\n", [("c_refocus.png", "png")]),
        "x-resize": ("resize 64 48\nwait 0.2\nresize 1 1\nquit\n", []),
        "x-bom": ("\ufeffquit\n", []),
        "x-devfull": ("screenshot /dev/full\nquit\n", []),
        "x-under-file": ("screenshot {D}/afile/x\nquit\n", []),
        "x-scroll": ("scroll refocus 1000\nscroll scene -1000\ndrag scene 0 0 5000 5000\nquit\n", []),
        "x-wait-quit": ("wait 0.5\nwait-converged\nquit\n", []),
    }
    for name, (text, outs) in XV.items():
        def setup(d, fx, text=text):
            cp("hci")(d, fx)
            open(os.path.join(d, "afile"), "w").close()
            open(os.path.join(d, "s.txt"), "w").write(text.replace("{D}", d))
        add(Case(f"script-{name}", "scripts", "view",
                 ["view", HCI, "--disparity", "0", "--window", "320x200", "--script", "{D}/s.txt", "--json"],
                 setup=setup, outputs=outs, xvfb=True, expect="any", words=("line", "script"),
                 post=no_dev_files))
    for j, val in enumerate(["/dev/full", "{D}/afile/x", "{D}", "", "/proc/self/x"]):
        add(Case(f"script-prefix-{j}", "scripts", "view",
                 ["view", HCI, "--disparity", "0", "--script", "{D}/s.txt", "--screenshot-prefix", val],
                 setup=chain(cp("hci"), write("afile", ""), write("s.txt", "quit\n")), expect="fail",
                 words=("prefix", "screenshot", "display"), post=no_dev_files))

    # ---------------- the depth cache -----------------------------------------------------------
    def cache_setup(mut):
        def f(d, fx):
            cp("grid")(d, fx)
            shutil.copytree(os.path.join(fx, "cache"), os.path.join(d, "cache"), symlinks=True)
            os.makedirs(os.path.join(d, "outside"))
            open(os.path.join(d, "outside/victim"), "w").write("keep me")
            if mut:
                mut(d, _cache_entry(os.path.join(d, "cache")))
        return f

    def bytes_edit(fn, which="pfm"):
        def m(d, key):
            p = key + "." + which
            open(p, "wb").write(fn(open(p, "rb").read()))
        return m

    CACHE = {
        "intact": None,
        "pfm-trunc": bytes_edit(lambda b: b[: len(b) // 2]),
        "pfm-empty": bytes_edit(lambda b: b""),
        "pfm-value": bytes_edit(lambda b: b[:-8] + struct.pack("<f", 0.25) + b[-4:]),
        "pfm-nan": bytes_edit(lambda b: b[:20] + b"\xff" * (len(b) - 20)),
        "pfm-header": bytes_edit(lambda b: b"Pf\n4294967295 4294967295\n-1\n" + b[b.index(b"\n-1") + 4:] if b"\n-1" in b else b),
        "pfm-grow": bytes_edit(lambda b: b + b"\0" * 100000),
        "json-trunc": bytes_edit(lambda b: b[: len(b) // 2], "json"),
        "json-empty": bytes_edit(lambda b: b"", "json"),
        "json-edit": bytes_edit(lambda b: b.replace(b"1", b"2", 1), "json"),
        "json-hash": bytes_edit(lambda b: re.sub(rb'("hash"\s*:\s*")[0-9a-fA-F]', rb"\g<1>0", b, count=1), "json"),
        "json-garbage": bytes_edit(lambda b: bytes(range(256)), "json"),
        "json-huge": bytes_edit(lambda b: b"[" * 1000000, "json"),
        "both-swapped": lambda d, k: (shutil.copy(k + ".json", k + ".tmp"), shutil.copy(k + ".pfm", k + ".json"), shutil.move(k + ".tmp", k + ".pfm")),
    }
    for kind in ["dir", "fifo", "dangling", "devzero", "devurandom", "loop"]:
        for which in ["pfm", "json"]:
            CACHE[f"{which}-{kind}"] = (lambda kind, which: lambda d, k: special(os.path.relpath(k + "." + which, d), kind)(d, None))(kind, which)
    CACHE["pfm-link-victim"] = lambda d, k: (os.remove(k + ".pfm"), os.symlink(os.path.join(d, "outside/victim"), k + ".pfm"))
    CACHE["json-link-victim"] = lambda d, k: (os.remove(k + ".json"), os.symlink(os.path.join(d, "outside/victim"), k + ".json"))
    CACHE["both-link-new"] = lambda d, k: (os.remove(k + ".pfm"), os.remove(k + ".json"),
                                           os.symlink(os.path.join(d, "outside/new.pfm"), k + ".pfm"),
                                           os.symlink(os.path.join(d, "outside/new.json"), k + ".json"))
    CACHE["valid-link-copy"] = lambda d, k: (shutil.copy(k + ".pfm", os.path.join(d, "outside/copy.pfm")), os.remove(k + ".pfm"),
                                             os.symlink(os.path.join(d, "outside/copy.pfm"), k + ".pfm"))

    def tmp_links(d, k):
        # Plant links at the temporary names a writer might use (KEY.pfm.tmp<PID>, …) for the
        # next few thousand PIDs, all pointing at outside/victim.
        os.remove(k + ".pfm")
        os.remove(k + ".json")
        with open("/proc/sys/kernel/ns_last_pid") as f:
            base = int(f.read())
        for pid in range(base, base + 3000):
            for suffix in (".pfm.tmp", ".json.tmp"):
                os.symlink(os.path.join(d, "outside/victim"), f"{k}{suffix}{pid}")
        for suffix in (".pfm.tmp", ".json.tmp", ".pfm.part", ".json.part", ".tmp"):
            os.symlink(os.path.join(d, "outside/victim"), k + suffix)
    CACHE["tmp-links"] = tmp_links
    CACHE["cache-is-file"] = lambda d, k: (shutil.rmtree(os.path.join(d, "cache")), open(os.path.join(d, "cache"), "w").write("x"))
    CACHE["cache-dangling"] = lambda d, k: (shutil.rmtree(os.path.join(d, "cache")), os.symlink(os.path.join(d, "nowhere"), os.path.join(d, "cache")))
    CACHE["cache-link-outside"] = lambda d, k: (shutil.rmtree(os.path.join(d, "cache")), os.symlink(os.path.join(d, "outside"), os.path.join(d, "cache")))
    CACHE["cache-devnull"] = lambda d, k: (shutil.rmtree(os.path.join(d, "cache")), os.symlink("/dev/null", os.path.join(d, "cache")))
    CACHE["cache-fifo"] = lambda d, k: (shutil.rmtree(os.path.join(d, "cache")), os.mkfifo(os.path.join(d, "cache")))
    CACHE["cache-full-of-junk"] = lambda d, k: [open(os.path.join(d, "cache", f"junk{i}.json"), "w").write("{") for i in range(200)]
    for name, mut in CACHE.items():
        for cmd, argv, outs in [("cloud", ["cloud", "{D}/grid", "-o", "{D}/c.ply", "--json"], [("c.ply", "ply")]),
                                ("render", ["render", "{D}/grid", "-o", "{D}/o.png", "--click", "24,24"], [("o.png", "png")])]:
            add(Case(f"cache-{name}-{cmd}", "cache", cmd, argv, setup=cache_setup(mut), outputs=outs,
                     env={"TILTFIELD_CACHE_DIR": "{D}/cache"}, post=cache_post,
                     words=("cache",)))
    add(Case("cache-env-empty", "cache", "cloud", ["cloud", "{D}/grid", "-o", "{D}/c.ply"], setup=cp("grid"),
             outputs=[("c.ply", "ply")], env={"TILTFIELD_CACHE_DIR": "", "HOME": "{D}/home", "XDG_CACHE_HOME": ""}))
    add(Case("cache-env-relative", "cache", "cloud", ["cloud", "{D}/grid", "-o", "{D}/c.ply"], setup=cp("grid"),
             outputs=[("c.ply", "ply")], env={"TILTFIELD_CACHE_DIR": "rel/cache"}))
    add(Case("cache-env-proc", "cache", "cloud", ["cloud", "{D}/grid", "-o", "{D}/c.ply"], setup=cp("grid"),
             outputs=[("c.ply", "ply")], env={"TILTFIELD_CACHE_DIR": "/proc/self"}))
    add(Case("cache-env-devnull", "cache", "cloud", ["cloud", "{D}/grid", "-o", "{D}/c.ply"], setup=cp("grid"),
             outputs=[("c.ply", "ply")], env={"TILTFIELD_CACHE_DIR": "/dev/null"}))

    # ---------------- paths that are not UTF-8, very long, or odd ------------------------------
    BAD = "\udcff\udcfe"  # bytes 0xff 0xfe once encoded (surrogateescape): not UTF-8
    def bad_copy(src, dst):
        return lambda d, fx: shutil.copytree(os.path.join(fx, src), os.path.join(d, dst), symlinks=True)
    PATHS = [
        ("lf-hci", ["render", "{D}/h" + BAD, "-o", "{D}/o.png", "--disparity", "0"], bad_copy("hci", "h" + BAD), [("o.png", "png")]),
        ("lf-grid", ["cloud", "{D}/g" + BAD, "-o", "{D}/c.ply"], bad_copy("grid", "g" + BAD), [("c.ply", "ply")]),
        ("lf-man", ["info", "{D}/m" + BAD], bad_copy("man", "m" + BAD), []),
        ("lf-video", ["render", "{D}/v" + BAD, "--frames", "1..2", "--disparity", "0", "-o", "{D}/f_{frame}.png"], bad_copy("video", "v" + BAD), [("f_*.png", "glob_png")]),
        ("out-render", ["render", HCI, "-o", "{D}/o" + BAD + ".png", "--disparity", "0"], cp("hci"), [("o" + BAD + ".png", "png")]),
        ("out-frames", ["render", "{D}/video", "--frames", "1..2", "--disparity", "0", "-o", "{D}/f" + BAD + "_{frame}.png"], cp("video"), [("f" + BAD + "_*.png", "glob_png")]),
        ("out-depth", ["depth", HCI, "-o", "{D}/d" + BAD + ".pfm", "--confidence", "{D}/c" + BAD + ".png"], cp("hci"), [("d" + BAD + ".pfm", "pfm")]),
        ("out-cloud", ["cloud", HCI, "-o", "{D}/c" + BAD + ".ply"], cp("hci"), [("c" + BAD + ".ply", "ply")]),
        ("out-synth", ["synth", "builtin:planes", "--out", "{D}/s" + BAD, "--grid", "2x2", "--size", "32x32"], None, [("s" + BAD, "dir_hci")]),
        ("out-demo", ["demo", "--scene", "planes", "-o", "{D}/d" + BAD], None, [("d" + BAD, "demojson")]),
        ("out-bench", ["bench", HCI, "--quick", "--no-scaling", "--out", "{D}/b" + BAD], cp("hci"), [("b" + BAD, "benchjson")]),
        ("out-md", ["depth-set", "--grid", "3", "--size", "48", "--scenes", "planes", "--variants", "sweep", "--markdown", "{D}/t" + BAD + ".md"], None, [("t" + BAD + ".md", "nonempty")]),
        ("gltf", ["synth", "{D}/e" + BAD + ".gltf", "--out", "{D}/s", "--grid", "2x2", "--size", "32x32"], cp("example.gltf", "e" + BAD + ".gltf"), [("s", "dir_hci")]),
        ("gltf-buffer", ["synth", "{D}/scene.gltf", "--out", "{D}/s", "--grid", "2x2", "--size", "32x32"],
         lambda d, fx: (shutil.copy(os.path.join(fx, "example.bin"), os.path.join(d, "b" + BAD + ".bin")),
                        json.dump(dict(json.load(open(os.path.join(fx, "ext.gltf"))), buffers=[{"byteLength": 1408, "uri": "b%FF%FE.bin"}]),
                                  open(os.path.join(d, "scene.gltf"), "w"))), [("s", "dir_hci")]),
        ("score", ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/g" + BAD + ".pfm"], chain(cp("hci"), cp("hci/gt_disp_lowres.pfm", "g" + BAD + ".pfm")), [("d.pfm", "pfm")]),
        ("script", ["view", HCI, "--disparity", "0", "--script", "{D}/s" + BAD + ".txt"], chain(cp("hci"), write("s" + BAD + ".txt", "quit\n")), []),
        ("script-shot", ["view", HCI, "--disparity", "0", "--script", "{D}/s.txt"], chain(cp("hci"), write("s.txt", "screenshot sh\xff\n".encode("latin-1"))), []),
        ("cache", ["cloud", "{D}/grid", "-o", "{D}/c.ply"], cp("grid"), [("c.ply", "ply")]),
        ("man-image", ["info", "{D}/man"], chain(cp("man"), lambda d, fx: (os.rename(os.path.join(d, "man/view_1_1.png"), os.path.join(d, "man/v" + BAD + ".png")),
                                                                   _sub(d, "man/tiltfield.json", [("view_1_1.png", "v\u00ff.png")]))), []),
        ("grid-names", ["info", "{D}/grid"], chain(cp("grid"), lambda d, fx: [os.rename(os.path.join(d, f"grid/view_{t:02d}_{s:02d}.png"),
                        os.path.join(d, f"grid/v{BAD}_{t}_{s}.png")) for t in range(3) for s in range(3)]), []),
        ("long-out", ["render", HCI, "-o", "{D}/" + "/".join(["d" * 200] * 25) + "/o.png", "--disparity", "0"], cp("hci"), []),
        ("long-lf", ["info", "{D}/" + "x" * 5000], None, []),
        ("dash-lf", ["info", "-"], None, []),
        ("nul-like", ["info", "{D}/a\tb\rc"], None, []),
    ]
    for name, argv, setup, outs in PATHS:
        env = {"TILTFIELD_CACHE_DIR": "{D}/c" + BAD} if name == "cache" else {}
        add(Case(f"path-{name}", "paths", argv[0], argv, setup=setup, outputs=outs, env=env))

    # ---------------- decompression bombs and huge declared sizes ------------------------------
    def bomb(w, h):
        raw = zlib.compressobj(9)
        row = b"\0" + b"\0" * (w * 3)
        data = b"".join(raw.compress(row) for _ in range(h)) + raw.flush()
        ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
        return b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", data) + png_chunk(b"IEND", b"")
    BOMBS = {"8192": (8192, 8192), "16384": (16384, 16384), "wide": (65535, 64)}
    for name, (w, h) in BOMBS.items():
        def setup(d, fx, w=w, h=h):
            cp("hci")(d, fx)
            cache = os.path.join(fx, f"bomb_{w}x{h}.png")
            if not os.path.exists(cache):
                import threading
                tmp = f"{cache}.tmp{threading.get_ident()}"
                open(tmp, "wb").write(bomb(w, h))
                os.replace(tmp, cache)
            for i in range(9):
                os.remove(os.path.join(d, f"hci/input_Cam{i:03d}.png"))
                os.link(cache, os.path.join(d, f"hci/input_Cam{i:03d}.png"))
            _sub(d, "hci/parameters.cfg", [("image_resolution_x_px = 48", f"image_resolution_x_px = {w}"),
                                           ("image_resolution_y_px = 48", f"image_resolution_y_px = {h}")])
            for g in ("gt_disp_lowres.pfm", "gt_depth_lowres.pfm"):
                os.remove(os.path.join(d, "hci", g))
        for cmd, argv, outs in [("info", ["info", HCI], []),
                                ("render", ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--size", "64x64"], [("o.png", "png")]),
                                ("depth", ["depth", HCI, "-o", "{D}/d.pfm"], [("d.pfm", "pfm")])]:
            add(Case(f"bomb-{name}-{cmd}", "bombs", cmd, argv, setup=setup, outputs=outs,
                     words=("size", "pixel", "memory", "limit", "large", "px")))
        def setup_one(d, fx, w=w, h=h, setup=setup):
            setup(d, fx)
            for i in range(9):
                if i != 4:
                    os.remove(os.path.join(d, f"hci/input_Cam{i:03d}.png"))
                    open(os.path.join(d, f"hci/input_Cam{i:03d}.png"), "wb").write(png_bytes(48, 48, seed=i))
            _sub(d, "hci/parameters.cfg", [(f"image_resolution_x_px = {w}", "image_resolution_x_px = 48"),
                                           (f"image_resolution_y_px = {h}", "image_resolution_y_px = 48")])
        add(Case(f"bomb-{name}-one-view", "bombs", "render", ["render", HCI, "-o", "{D}/o.png", "--disparity", "0"],
                 setup=setup_one, outputs=[("o.png", "png")], words=("input_Cam004",)))
        add(Case(f"bomb-{name}-score", "bombs", "depth", ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/gt.pfm"],
                 setup=chain(cp("hci"), write("gt.pfm", b"Pf\n%d %d\n-1\n" % (w, h))), words=("gt.pfm",)))

    # ---------------- every command, plain and odd (smoke of the accepted path) -----------------
    for scene in ["demo", "planes", "tilted", "room", "tower", "depths", "layers", "nope", "", "DEMO", "demo/../demo"]:
        add(Case(f"misc-info-builtin-{scene or 'empty'}", "misc", "info", ["info", f"builtin:{scene}", "--json"], words=("scene", "builtin")))
    for aa in ["on", "off", "maybe", ""]:
        for lf in ["{D}/hci", "{D}/grid", "{D}/man", "{D}/video"]:
            add(Case(f"misc-render-aa-{aa or 'empty'}-{lf[4:]}", "misc", "render",
                     ["render", lf, "-o", "{D}/o.png", "--focus", "2.5", "--antialias", aa],
                     setup=chain(cp("hci"), cp("grid"), cp("man"), cp("video")), outputs=[("o.png", "png")],
                     words=("antialias",)))
    for strat in ["fragment", "batched", "batched:1", "batched:0", "batched:999999", "compute", "batched:-1", "batched:x"]:
        for filt in ["hardware", "bicubic"]:
            add(Case(f"misc-render-strategy-{strat}-{filt}", "misc", "render",
                     ["render", HCI, "-o", "{D}/o.exr", "--disparity", "0.2", "--strategy", strat, "--filter", filt,
                      "--accumulation", "rgba16f", "--warps", "ssbo", "--storage", "srgb8"],
                     setup=cp("hci"), outputs=[("o.exr", "exr")], words=("strategy", "batched")))
    for dev in ["0", "1", "99", "-1", "llvmpipe", "nonexistent", "", "18446744073709551615"]:
        add(Case(f"misc-render-device-{dev or 'empty'}", "misc", "render",
                 ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--device", dev], setup=cp("hci"),
                 outputs=[("o.png", "png")], words=("device",)))
        add(Case(f"misc-env-device-{dev or 'empty'}", "misc", "depth", ["depth", HCI, "-o", "{D}/d.pfm"], setup=cp("hci"),
                 outputs=[("d.pfm", "pfm")], env={"TILTFIELD_DEVICE": dev}, words=("device", "TILTFIELD_DEVICE")))
    for j, args in enumerate([["devices"], ["demo", "--list"], ["synth", "--list"], ["info", "builtin:demo"],
                              ["info", "/"], ["info", "/proc"], ["info", "/dev"], ["info", "."], ["info", ""],
                              ["render"], ["render", HCI], ["render", HCI, "-o", "{D}/o.png"],
                              ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--focus", "2"],
                              ["render", HCI, "-o", "{D}/o.png", "--tilt", "5"],
                              ["render", HCI, "-o", "{D}/o.png", "--focus", "2", "--tilt", "90"],
                              ["render", HCI, "-o", "{D}/o.png", "--focus", "2", "--tilt", "89.9999"],
                              ["render", HCI, "-o", "{D}/o.png", "--focus", "0.001"],
                              ["render", HCI, "-o", "{D}/o.png", "--focus", "1e6"],
                              ["render", HCI, "-o", "{D}/o.png", "--disparity", "1000"],
                              ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--aperture", "gaussian", "--aperture-radius", "1e-9"],
                              ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--aperture", "square", "--aperture-radius", "0"],
                              ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--aperture", "disk", "--view", "5,5"],
                              ["render", HCI, "-o", "{D}/o.png", "--disparity", "0", "--average", "encoded", "--json"],
                              ["render", "{D}/grid", "-o", "{D}/o.png", "--disparity", "0", "--antialias", "on"],
                              ["render", "{D}/video", "-o", "{D}/o.png", "--disparity", "0", "--frame", "2", "--json"],
                              ["render", "{D}/video", "-o", "{D}/o.png", "--focus", "0.001"],
                              ["render", "{D}/video", "--frames", "1..3", "-o", "{D}/o_{frame}.png", "--focus", "0.001"],
                              ["cloud", "{D}/video", "-o", "{D}/c.ply", "--cameras", "--frame", "3"],
                              ["cloud", HCI, "-o", "{D}/c.ply", "--cameras", "--points-3d", "0,0,2,1,0,2,0,1,2"],
                              ["depth", "{D}/video", "-o", "{D}/d.exr", "--kind", "depth", "--confidence", "{D}/c.png", "--json"],
                              ["depth", "{D}/man", "-o", "{D}/d.pfm", "--naive"],
                              ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/hci/gt_disp_lowres.pfm", "--json"],
                              ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/hci/gt_depth_lowres.pfm"],
                              ["depth", HCI, "-o", "{D}/d.pfm", "--cost", "mean", "--aggregation", "none", "--no-fit", "--include-dark"],
                              ["depth", HCI, "-o", "{D}/d.pfm", "--kind", "bogus"],
                              ["bench", HCI, "--quick", "--no-scaling", "--disparity", "0.5", "--out", "{D}/b"],
                              ["bench", "{D}/grid", "--quick", "--no-scaling", "--out", "{D}/b"],
                              ["bench", "--quick", "--no-scaling", "--out", "{D}/b", "--antialias", "off"],
                              ["synth", "builtin:layers", "--out", "{D}/s", "--grid", "3x3", "--size", "32x32", "--layout", "manifest", "--rig", "converging"],
                              ["synth", "builtin:demo", "--out", "{D}/s", "--grid", "3x3", "--size", "32x32", "--rig", "converging"],
                              ["synth", "{D}/example.gltf", "--out", "{D}/s", "--grid", "2x2", "--size", "32x32"],
                              ["synth", "{D}/example.glb", "--out", "{D}/s", "--grid", "2x2", "--size", "32x32", "--layout", "manifest"],
                              ["synth", "builtin:planes", "--out", "{D}/hci", "--grid", "2x2", "--size", "32x32"],
                              ["depth-set", "--grid", "3", "--size", "48", "--scenes", "planes", "--hci", "{D}/hci", "--variants", "sweep"],
                              ["depth-set", "--grid", "3", "--size", "48", "--scenes", "planes", "--hci", "{D}/grid", "--variants", "sweep"],
                              ["view", "builtin:nope"], ["view", "{D}/nothing"], ["view", HCI, "--present", "bogus"],
                              ["bogus"], ["--version"], ["render", "--help"]]):
        outs = []
        if "-o" in args and args[0] in ("render", "depth", "cloud"):
            o = args[args.index("-o") + 1]
            if "{frame}" not in o:
                outs = [(o.replace("{D}/", ""), {"png": "png", "exr": "exr", "pfm": "pfm", "ply": "ply"}[o.rsplit(".", 1)[1]])]
        add(Case(f"misc-cmd-{j}", "misc", args[0].lstrip("-") if args else "none", args,
                 setup=chain(cp("hci"), cp("grid"), cp("man"), cp("video"), cp("example.gltf"), cp("example.bin"), cp("example.glb")),
                 outputs=outs))
    round3_cases(add)
    return C


def _mostly_opaque(d, fx, rc, out, err):
    """A render that succeeded must not be mostly transparent (the 1e30 depth map made 84-91 %
    of it transparent without a word)."""
    p = os.path.join(d, "o.png")
    if rc == 0 and os.path.exists(p):
        a = np.asarray(Image.open(p).convert("RGBA"))[..., 3]
        frac = float((a == 0).mean())
        if frac > 0.05:
            return ("lost", f"{100 * frac:.0f} % of the output is transparent")
    return None


def _short_message(d, fx, rc, out, err):
    """Numbers in messages are printed compactly, not as 309 digits."""
    if rc != 0 and any(len(l) > 600 for l in err.splitlines()):
        return ("unclear", "a message line longer than 600 characters (a number printed in full?)")
    return None


def round3_cases(add):
    """Issue 42 (round 3): the cases the third campaign found, each with what it must end as."""
    HCI = "{D}/hci"
    aa = ["antialias-set", "--size", "48", "--cases", "layers", "--no-estimate"]
    for j, extra in enumerate([
        ["--truth-grid", "1000000", "--frames", "1", "--supersamples", "1"],
        ["--truth-grid", "9", "--supersamples", "1000000"], ["--truth-grid", "4294967295"],
        ["--truth-grid", "600"], ["--truth-grid", "258"], ["--truth-grid", "8"], ["--truth-grid", "0"],
        ["--truth-grid", "-1"], ["--frames", "1000000"], ["--frames", "1001"], ["--frames", "0"],
        ["--frames", "-3"], ["--supersamples", "0"], ["--supersamples", "17"], ["--supersamples", "-1"],
    ]):
        add(Case(f"r3-aaset-{j}", "round3", "antialias-set", aa + extra, expect="fail",
                 words=("truth-grid", "supersamples", "frames")))
    for j, v in enumerate(["-1", "-0.5", "-1e308", "-inf", "-0"]):
        add(Case(f"r3-aperture-neg-{j}", "round3", "render",
                 ["render", HCI, "--disparity", "0", "--aperture-radius", v, "-o", "{D}/o.png"],
                 setup=cp("hci"), outputs=[("o.png", "png")], words=("aperture-radius",)))
    for j, (opt, v) in enumerate([("--stride", "-1"), ("--normal-window", "-9"), ("--plane-size", "-2")]):
        add(Case(f"r3-cloud-neg-{j}", "round3", "cloud", ["cloud", HCI, "-o", "{D}/c.ply", "--focus", "2", opt, v],
                 setup=cp("hci"), outputs=[("c.ply", "ply")], words=(opt,)))
    add(Case("r3-aif-alone-hci", "round3", "render", ["render", HCI, "--all-in-focus", "-o", "{D}/o.png"],
             setup=cp("hci"), outputs=[("o.png", "png")], expect="ok", post=_mostly_opaque))
    add(Case("r3-aif-alone-grid", "round3", "render", ["render", "{D}/grid", "--all-in-focus", "-o", "{D}/o.png"],
             setup=cp("grid"), outputs=[("o.png", "png")], words=("all-in-focus", "unknown")))
    for j, w in enumerate(["1000", "2", "1e308", "0.5"]):
        add(Case(f"r3-cloud-slab-{j}", "round3", "cloud", ["cloud", HCI, "-o", "{D}/c.ply", "--focus", "2", "--slab", w],
                 setup=cp("hci"), outputs=[("c.ply", "ply")], words=("slab",)))
    for j, (val, holes) in enumerate([(1e30, 0), (-1e30, 0), (1e6, 0), (0.5, 100), (float("inf"), 0)]):
        def absurd(val=val, holes=holes):
            def f(d, fx):
                cp("hci")(d, fx)
                vals = np.full(48 * 48, val, "<f4")
                vals[:holes] = 1e30
                open(os.path.join(d, "hci/gt_disp_lowres.pfm"), "wb").write(pfm_bytes(48, 48, vals.tolist()))
                os.remove(os.path.join(d, "hci/gt_depth_lowres.pfm"))
            return f
        add(Case(f"r3-depth-absurd-{j}", "round3", "render", ["render", HCI, "--disparity", "0", "-o", "{D}/o.png"],
                 setup=absurd(), outputs=[("o.png", "png")], expect="ok", post=_mostly_opaque))
    for j, click in enumerate(["16,12", "8,8", "24,16"]):
        add(Case(f"r3-video-click-{j}", "round3", "render",
                 ["render", "{D}/video", "--frames", "1..2", "--click", click, "-o", "{D}/f_{frame}.png"],
                 setup=cp("video"), words=("click", "normal", "depth", "confidence")))
    for kind in ["dir", "fifo", "dangling", "devzero", "devnull", "loop"]:
        add(Case(f"r3-grid-view-{kind}", "round3", "render", ["render", "{D}/grid", "--disparity", "0", "-o", "{D}/o.png"],
                 setup=chain(cp("grid"), special("grid/view_01_01.png", kind)), expect="fail",
                 words=SPECIAL_WORDS[kind] + ("view_01_01",)))
    for j, pts in enumerate(["10,10,20,20,30,30", "5,5,5,5,5,5", "0,0,47,0,20,0", "1,2,3,4,5,6"]):
        add(Case(f"r3-collinear-{j}", "round3", "render", ["render", HCI, "--points", pts, "-o", "{D}/o.png"],
                 setup=cp("hci"), expect="fail", words=("line", "collinear", "coincide")))
    for j, n in enumerate([1, 20, 30, 31]):
        add(Case(f"r3-score-tiny-{j}", "round3", "depth", ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/t.pfm"],
                 setup=chain(cp("hci"), write("t.pfm", pfm_bytes(n, n))), outputs=[("d.pfm", "pfm")],
                 words=("too small", "border", "the views")))
    for j, argv in enumerate([
        ["render", "{D}/link", "--disparity", "0", "-o", "{D}/o.png"], ["info", "{D}/link"],
        ["cloud", "{D}/link", "-o", "{D}/c.ply"], ["depth", HCI, "-o", "{D}/d.pfm", "--score", "{D}/link"],
        ["synth", "{D}/link", "--out", "{D}/s"], ["view", "{D}/link"],
        ["render", HCI, "--disparity", "0", "-o", "{D}/o.png", "--size", "8x8", "--view", "1,1"],
    ]):
        setup = chain(cp("hci"), lambda d, fx: os.symlink(os.path.join(d, "gone", "target"), os.path.join(d, "link")))
        if j == 6:  # a view of the HCI folder that is a dangling link
            setup = chain(cp("hci"), special("hci/input_Cam004.png", "dangling"))
        add(Case(f"r3-dangling-{j}", "round3", argv[0], argv, setup=setup, expect="fail", words=("dangling",)))
    for j, args in enumerate([["--disparity=1e308"], ["--disparity=-1e308"], ["--disparity", "0", "--slab=1e308"],
                              ["--disparity", "0", "--view", "1e308,0"], ["--focus", "3", "--tilt=1e308"],
                              ["--disparity", "0", "--aperture-radius=-1e308"]]):
        add(Case(f"r3-huge-{j}", "round3", "render", ["render", HCI, "-o", "{D}/o.png"] + args,
                 setup=cp("hci"), outputs=[("o.png", "png")], post=_short_message))


def _black(w, h):
    bio = io.BytesIO()
    Image.new("RGB", (w, h)).save(bio, "PNG")
    return bio.getvalue()


def _sub(d, rel, pairs):
    p = os.path.join(d, rel)
    t = open(p).read()
    for a, b in pairs:
        t = t.replace(a, b)
    open(p, "w").write(t)


def _keep_views(path, keep):
    m = json.load(open(path))
    m["views"] = [v for i, v in enumerate(m["views"]) if i in keep]
    for i, v in enumerate(m["views"]):
        v["grid"] = {"s": i, "t": 0}
    json.dump(m, open(path, "w"))


def _glob(d, rel, ext):
    base = os.path.join(d, rel)
    return [os.path.join(base, n) for n in sorted(os.listdir(base)) if n.endswith(ext)]


def _is_fifo(p):
    import stat
    try:
        return stat.S_ISFIFO(os.lstat(p).st_mode)
    except OSError:
        return False


def _cache_entry(cache):
    keys = sorted({n.rsplit(".", 1)[0] for n in os.listdir(cache) if n.endswith(".json")})
    return os.path.join(cache, keys[0])


# Post-checks: return a (class, note) for a finding, or None.

def score_sane(d, fx, rc, out, err):
    if rc == 0 and ("badpix" in out.lower() or "mse" in out.lower()):
        if "nan" in out.lower() and "allnan" not in d:
            return ("lost", "score printed NaN")
    if rc == 0 and any(k in d for k in ("allnan", "allinf")):
        return ("lost", "scored against a ground truth without a single finite value")
    return None


def out_post(d, fx, rc, out, err):
    o = open(os.path.join(d, ".outpath")).read()
    if os.path.isdir(os.path.join(d, "outside")):
        if open(os.path.join(d, "outside/victim.png")).read() != "keep" or len(os.listdir(os.path.join(d, "outside"))) != 1:
            return ("leftover", "wrote through the link into outside/")
    if rc == 0 and (o in ("/dev/full", "/dev/null") or _is_fifo(o) or o.startswith("/proc")
                    or (os.path.islink(o) and os.readlink(o).startswith("/dev/"))):
        return ("lost", f"exit 0 writing to {o!r}")
    if os.path.exists(os.path.join(d, "target")):
        return ("leftover" if rc else "lost", "wrote through a dangling link (created its target)")
    if rc != 0 and os.path.lexists(os.path.join(d, "x")):
        return ("leftover", "failed run left the folder x/ behind")
    return None


def no_dev_files(d, fx, rc, out, err):
    for n in ("/dev/full_refocus.png", "/dev/full_scene.png", "/dev/full.json", "/dev/full_window.png", "/proc/self/x_refocus.png"):
        if os.path.lexists(n):
            return ("leftover", f"created {n}")
    if os.path.exists(os.path.join(d, "afile")) and os.path.isdir(os.path.join(d, "afile")):
        return ("leftover", "afile became a folder")
    return None


def cache_post(d, fx, rc, out, err):
    victim = os.path.join(d, "outside/victim")
    if os.path.exists(victim) and open(victim).read() != "keep me":
        return ("leftover", "cache write went through a planted link: outside/victim changed")
    extra = [n for n in os.listdir(os.path.join(d, "outside")) if n not in ("victim", "copy.pfm")] \
        if os.path.isdir(os.path.join(d, "outside")) and not os.path.islink(os.path.join(d, "cache")) else []
    if extra:
        return ("leftover", f"files created outside the cache: {extra}")
    c = os.path.join(d, "cache")
    if os.path.isdir(c) and not os.path.islink(c):
        tmps = [n for n in os.listdir(c) if ".tmp" in n and not os.path.islink(os.path.join(c, n))]
        if tmps:
            return ("leftover", f"temporary files left in the cache: {tmps}")
    # A damaged/edited entry must not be used as cached.
    name = os.path.basename(d)
    damaged = any(k in name for k in ("pfm-", "json-", "both-")) and "link-copy" not in name
    if rc == 0 and damaged and '"cached": true' in out:
        return ("lost", "a damaged or edited cache entry was used as cached")
    return None


# --------------------------------------------------------------------------------------------
# Output validation
# --------------------------------------------------------------------------------------------


def check_png(p, need_alpha=True):
    with Image.open(p) as im:
        im.load()
        a = np.asarray(im)
    if need_alpha and im.mode in ("RGBA", "LA") and a[..., -1].max() == 0:
        return "fully transparent image"
    return None


def check_pfm(p):
    data = open(p, "rb").read()
    parts = data.split(b"\n", 3)
    if len(parts) < 4 or parts[0] not in (b"Pf", b"PF"):
        return "not a PFM"
    w, h = map(int, parts[1].split())
    scale = float(parts[2])
    ch = 3 if parts[0] == b"PF" else 1
    arr = np.frombuffer(parts[3], dtype="<f4" if scale < 0 else ">f4")
    if arr.size != w * h * ch:
        return f"PFM holds {arr.size} values for {w}x{h}"
    if not np.isfinite(arr).any():
        return "PFM without a single finite value"
    return None


def check_exr(p):
    data = open(p, "rb").read()
    if data[:4] != b"\x76\x2f\x31\x01" or len(data) < 100:
        return "not an EXR"
    return None


def check_ply(p):
    data = open(p, "rb").read()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        return "not a PLY"
    hdr = data[:end].decode("ascii", "replace")
    m = re.search(r"element vertex (\d+)", hdr)
    if not m:
        return "PLY without vertices"
    n = int(m.group(1))
    props = re.findall(r"property (\w+) (\w+)", hdr.split("element face")[0])
    size = {"float": 4, "uchar": 1, "double": 8, "int": 4, "uint": 4}
    vsz = sum(size.get(t, 0) for t, _ in props)
    body = len(data) - end - len("end_header\n")
    if body < n * vsz:
        return f"PLY body {body} bytes < {n} vertices x {vsz}"
    if n == 0:
        return "PLY with no vertices"
    v = np.frombuffer(data[end + 11: end + 11 + n * vsz], dtype=np.uint8).reshape(n, vsz)
    xyz = v[:, :12].copy().view("<f4")
    if not np.isfinite(xyz).all():
        return "PLY with non-finite positions"
    return None


def check_output(d, path, kind):
    p = path if os.path.isabs(path) else os.path.join(d, path)
    if kind == "glob_png" or kind == "any_png":
        import glob as g
        pat = p if kind == "glob_png" else os.path.join(d, "**", "*.png")
        files = [f for f in g.glob(pat, recursive=True) if "/hci/" not in f and "/video/" not in f]
        if not files:
            return "no frame written"
        for f in files:
            e = check_png(f)
            if e:
                return f"{os.path.basename(f)}: {e}"
        return None
    if not os.path.lexists(p):
        return f"{path} missing"
    if kind.startswith("dir_") or kind in ("demojson", "benchjson"):
        if not os.path.isdir(p):
            return f"{path} is not a folder"
        names = os.listdir(p)
        if kind == "dir_hci" and not ("parameters.cfg" in names or "tiltfield.json" in names):
            return f"{path}: no parameters.cfg/tiltfield.json"
        if kind == "dir_man" and "tiltfield.json" not in names:
            return f"{path}: no tiltfield.json"
        if kind == "demojson":
            return None if "demo.json" in names else "no demo.json"
        if kind == "benchjson":
            return None if "bench.json" in names else "no bench.json"
        for n in names:
            q = os.path.join(p, n)
            if os.path.isfile(q) and os.path.getsize(q) == 0:
                return f"{n} empty"
            if n.endswith(".png"):
                try:
                    with Image.open(q) as im:
                        im.load()
                except Exception as e:  # noqa: BLE001
                    return f"{n} unreadable: {e}"
        return None
    if not os.path.isfile(p):
        return f"{path} is not a regular file"
    if os.path.getsize(p) == 0:
        return f"{path} empty"
    try:
        if kind == "any_output":
            kind = {"png": "png", "exr": "exr", "pfm": "pfm", "ply": "ply"}.get(p.rsplit(".", 1)[-1].lower(), "nonempty")
        if kind == "png":
            return check_png(p)
        if kind == "pfm":
            return check_pfm(p)
        if kind == "exr":
            return check_exr(p)
        if kind == "ply":
            return check_ply(p)
        if kind == "json":
            json.load(open(p))
    except Exception as e:  # noqa: BLE001
        return f"{path} unreadable: {e}"
    return None


WROTE = re.compile(r"^\s*wrote (.+)$", re.M)


def wrote_paths(text):
    out = []
    for m in WROTE.finditer(text):
        s = m.group(1).split(" (")[0].split(" in ")[0]
        for tok in s.split(", "):
            tok = tok.strip()
            # a name printed lossily (U+FFFD for bytes that are not UTF-8) cannot be checked by name
            if tok and " " not in tok and "\ufffd" not in tok and ("/" in tok or "." in tok):
                out.append(tok)
    return out


# --------------------------------------------------------------------------------------------
# Running and classifying
# --------------------------------------------------------------------------------------------


def subst(s, d, fx, outp):
    return s.replace("{D}", d).replace("{F}", fx).replace("{OUT}", outp)


def run_case(case, binary, work, fx, base_env):
    d = os.path.join(work, "runs", case.cid.replace("/", "_"))
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    try:
        if case.setup:
            case.setup(d, fx)
    except Exception as e:  # noqa: BLE001
        return {"id": case.cid, "group": case.group, "cmd": case.cmd, "class": "setup-error", "note": repr(e),
                "argv": [], "rc": None, "secs": 0, "stderr_tail": ""}
    outp = open(os.path.join(d, ".outpath")).read() if os.path.exists(os.path.join(d, ".outpath")) else ""
    argv = [subst(a, d, fx, outp) for a in case.argv]
    env = dict(base_env)
    env["TILTFIELD_CACHE_DIR"] = os.path.join(d, "cache")
    for k, v in case.env.items():
        env[k] = subst(v, d, fx, outp)
    full = [binary] + argv
    if case.xvfb:
        full = ["xvfb-run", "-a", "-s", "-screen 0 640x480x24"] + full
    shell = f"ulimit -v {ULIMIT_KB}; exec timeout -s KILL {TIMEOUT} \"$@\""
    t0 = time.time()
    p = subprocess.run(["bash", "-c", shell, "_"] + full, cwd=d, env=env, stdin=subprocess.DEVNULL,
                       capture_output=True, timeout=TIMEOUT + 30)
    secs = time.time() - t0
    rc = p.returncode
    out = p.stdout.decode("utf-8", "replace")
    err = p.stderr.decode("utf-8", "replace")
    cls, note = classify(case, d, rc, secs, out, err, outp)
    if cls in ("accepted", "accepted?") and case.followup:
        fa = [subst(a, d, fx, outp) for a in case.followup]
        q = subprocess.run(["bash", "-c", shell, "_", binary] + fa, cwd=d, env=env, stdin=subprocess.DEVNULL,
                           capture_output=True, timeout=TIMEOUT + 30)
        if q.returncode != 0:
            cls, note = "lost", "wrote output tiltfield itself refuses: " + q.stderr.decode("utf-8", "replace").strip()[-300:]
    if case.post and cls not in ("panic", "abort", "hang"):
        try:
            r = case.post(d, fx, rc, out, err)
        except Exception as e:  # noqa: BLE001
            r = None
            note = (note or "") + f" (post-check error {e!r})"
        if r:
            cls, note = r
    rec = {"id": case.cid, "group": case.group, "cmd": case.cmd, "class": cls, "note": note,
           "argv": [("xvfb-run -a " if case.xvfb else "") + shlex.join(full if not case.xvfb else full[4:])],
           "env": {k: subst(v, d, fx, outp) for k, v in case.env.items()},
           "rc": rc, "secs": round(secs, 2), "stderr_tail": "\n".join(err.strip().splitlines()[-6:]),
           "stdout_tail": "\n".join(out.strip().splitlines()[-3:])[-600:], "dir": d}
    if cls in ("clean", "accepted"):
        shutil.rmtree(d, ignore_errors=True)
    return rec


VALIDATION = re.compile(r"VUID-|Validation Error|validation layer:.*error", re.I)


def classify(case, d, rc, secs, out, err, outp):
    low = err.lower()
    if rc in (137, -9) and secs >= TIMEOUT - 1:
        return "hang", f"killed after {secs:.0f} s"
    if "panicked" in err or rc == 101:
        return "panic", None
    if rc < 0 or rc >= 128:
        if "memory allocation of" in err:
            return "abort", "allocation failure abort"
        return "abort", f"signal/exit {rc}"
    if VALIDATION.search(err) or VALIDATION.search(out):
        return "validation", None
    if rc == 0:
        problems = []
        for path, kind in case.outputs:
            e = check_output(d, subst(path, d, "", outp), kind)
            if e:
                problems.append(e)
        for w in ([] if "\n" in outp or any("\n" in a for a in case.argv) else wrote_paths(out + "\n" + err)):
            p = w if os.path.isabs(w) else os.path.join(d, w)
            if w.startswith("/dev/") or _is_fifo(p):
                problems.append(f"'wrote {w}' into a device/FIFO")
            elif not os.path.exists(p) or (os.path.isfile(p) and os.path.getsize(p) == 0):
                problems.append(f"'wrote {w}' but it is not there")
        if problems:
            return "lost", "; ".join(problems)
        if case.expect == "fail":
            return "accepted?", "exit 0 where a refusal was expected"
        return "accepted", None
    # non-zero, not a crash
    lines = [l for l in err.strip().splitlines() if l.strip()]
    if not lines:
        return "unclear", "non-zero exit with an empty stderr"
    if "backtrace" in low:
        return "unclear", "backtrace in stderr"
    errs = [l for l in lines if re.match(r"^(error|Error)\b", l)]
    if not errs:
        return "unclear", "no 'error' line"
    if rc == 2:
        return "clean", None  # clap usage error (multi-line usage by design)
    if case.words:
        # the run folder's name holds the case id: keep it out of the match
        msg = " ".join(errs).replace(d, "{D}").lower()
        words = list(case.words)
        for w in case.words:  # option names: any of their words will do ("antialias-samples" -> "samples")
            words += [x for x in re.split(r"[-_ ]", w) if len(x) > 3]
        if not any(w.lower() in msg for w in words):
            return "unclear", "message does not name an expected word: " + ", ".join(case.words[:6])
    return "clean", None


CLASSES = ["clean", "accepted", "accepted?", "unclear", "panic", "abort", "hang", "lost", "validation", "leftover", "setup-error"]


def summary(results, findings_path):
    byc = collections.Counter(r["class"] for r in results)
    bycmd = collections.defaultdict(collections.Counter)
    for r in results:
        bycmd[r["cmd"]][r["class"]] += 1
    cls = [c for c in CLASSES if byc.get(c)]
    print(f"\n{len(results)} runs")
    w = max(10, max((len(c) for c in bycmd), default=0))
    print(f"{'command':<{w}} " + " ".join(f"{c:>10}" for c in cls) + f" {'total':>7}")
    for cmd in sorted(bycmd):
        print(f"{cmd:<{w}} " + " ".join(f"{bycmd[cmd].get(c, 0):>10}" for c in cls) + f" {sum(bycmd[cmd].values()):>7}")
    print(f"{'all':<{w}} " + " ".join(f"{byc.get(c, 0):>10}" for c in cls) + f" {len(results):>7}")
    bad = [r for r in results if r["class"] not in ("clean", "accepted")]
    with open(findings_path, "w", errors="backslashreplace") as f:
        for r in sorted(bad, key=lambda r: (CLASSES.index(r["class"]) if r["class"] in CLASSES else 99, r["id"])):
            f.write(f"## [{r['class']}] {r['id']}  (exit {r['rc']}, {r['secs']} s)\n")
            if r.get("env"):
                f.write("env: " + " ".join(f"{k}={shlex.quote(v)}" for k, v in r["env"].items()) + "\n")
            f.write("$ " + " ".join(r["argv"]) + "\n")
            if r.get("note"):
                f.write(f"note: {r['note']}\n")
            f.write("stderr tail:\n" + "".join("    " + l[:2000] + "\n" for l in (r["stderr_tail"] or "").splitlines()))
            if r.get("stdout_tail"):
                f.write("stdout tail:\n" + "".join("    " + l + "\n" for l in r["stdout_tail"].splitlines()))
            f.write(f"run folder: {r.get('dir')}\n\n")
    print(f"findings (non-clean, non-accepted): {len(bad)} -> {findings_path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True, help="the tiltfield binary")
    ap.add_argument("--work", required=True, help="work folder (fixtures, run folders, results)")
    ap.add_argument("--group", action="append", help="only these groups (repeatable)")
    ap.add_argument("--match", help="only case ids containing this text")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--limit", type=int, help="at most this many new runs")
    ap.add_argument("--every", type=int, default=1,
                    help="a proportional subset: every K-th selected case of each group (seeded order kept)")
    ap.add_argument("--fresh", action="store_true", help="forget earlier results")
    ap.add_argument("--rerun", action="store_true", help="run matching cases again even if done")
    ap.add_argument("--summary", action="store_true", help="only print the table from results so far")
    ap.add_argument("--list-groups", action="store_true")
    ap.add_argument("--list", action="store_true", help="list case ids")
    a = ap.parse_args()
    binary = os.path.abspath(a.bin)
    work = os.path.abspath(a.work)
    os.makedirs(work, exist_ok=True)
    res_path = os.path.join(work, "results.jsonl")
    findings = os.path.join(work, "findings.md")
    all_cases = cases()
    ids = collections.Counter(c.cid for c in all_cases)
    dup = [k for k, v in ids.items() if v > 1]
    if dup:
        raise SystemExit(f"duplicate case ids: {dup[:5]}")
    if a.list_groups:
        for g, n in collections.Counter(c.group for c in all_cases).items():
            print(f"{g:10} {n}")
        print(f"{'total':10} {len(all_cases)}")
        return
    sel = [c for c in all_cases if (not a.group or c.group in a.group) and (not a.match or a.match in c.cid)]
    if a.every > 1:
        seen = collections.Counter()
        keep = []
        for c in sel:
            if seen[c.group] % a.every == 0:
                keep.append(c)
            seen[c.group] += 1
        sel = keep
    if a.list:
        for c in sel:
            print(c.cid, shlex.join(c.argv))
        return
    if a.fresh and os.path.exists(res_path):
        os.remove(res_path)
    results = {}
    if os.path.exists(res_path):
        for line in open(res_path):
            r = json.loads(line)
            results[r["id"]] = r
    known = {c.cid for c in all_cases}
    if a.summary:
        summary([r for r in results.values() if r["id"] in known], findings)
        return
    base_env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    base_env.setdefault("VK_DRIVER_FILES", LVP)
    base_env["TILTFIELD_VALIDATION"] = "1"
    base_env.pop("RUST_BACKTRACE", None)
    fx = os.path.join(work, "fixtures")
    build_fixtures(fx, binary, dict(base_env, TILTFIELD_CACHE_DIR=os.path.join(work, "fixture-cache")))
    todo = [c for c in sel if a.rerun or c.cid not in results]
    if a.limit:
        todo = todo[: a.limit]
    print(f"{len(todo)} runs to do ({len(sel)} selected, {len(all_cases)} in all)", flush=True)
    t0 = time.time()
    with open(res_path, "a") as rf, concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        futs = {ex.submit(run_case, c, binary, work, fx, base_env): c for c in todo}
        for i, fut in enumerate(concurrent.futures.as_completed(futs), 1):
            c = futs[fut]
            try:
                r = fut.result()
            except Exception as e:  # noqa: BLE001
                r = {"id": c.cid, "group": c.group, "cmd": c.cmd, "class": "setup-error", "note": repr(e), "argv": [],
                     "rc": None, "secs": 0, "stderr_tail": ""}
            results[r["id"]] = r
            rf.write(json.dumps(r) + "\n")
            rf.flush()
            if r["class"] not in ("clean", "accepted"):
                last = ((r["stderr_tail"] or "").splitlines() or [""])[-1][:240]
                print(f"[{i}/{len(todo)} {time.time() - t0:.0f}s] {r['class']:10} {r['id']}: {(r.get('note') or '')[:160]} "
                      f"| {last}", flush=True)
            elif i % 50 == 0:
                print(f"[{i}/{len(todo)} {time.time() - t0:.0f}s]", flush=True)
    summary([r for r in results.values() if r["id"] in known], findings)


if __name__ == "__main__":
    main()
