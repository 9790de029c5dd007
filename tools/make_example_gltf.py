#!/usr/bin/env python3
"""Writes tests/data/example.gltf: a small self-contained glTF 2.0 scene for `tiltfield synth`
and its tests (standard library only; the buffer and the texture are embedded as data URIs),
and tests/data/example.glb: the same scene as binary glTF (buffer in the BIN chunk).

Content (glTF frame: y up, metres): a 4 m × 4 m floor at y = 0 with a repeating checker texture
(sRGB PNG, sampler REPEAT, uv 0..4); a 1 m cube with per-vertex colours (COLOR_0) and a
baseColorFactor, turned 30° about y by its node and standing on the floor; a 0.6 m textured
card hanging at z = -1; a perspective camera (yfov 0.8 rad) at (0, 1.2, 4) pitched 15° down.
"""
import base64, json, math, struct, zlib
from pathlib import Path


def png(width, height, rgb_rows):
    raw = b"".join(b"\x00" + bytes(row) for row in rgb_rows)
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def checker(n, cell, a, b):
    return [[c for x in range(n) for c in (a if ((x // cell) + (y // cell)) % 2 == 0 else b)] for y in range(n)]


def stripes(n):
    rows = []
    for y in range(n):
        row = []
        for x in range(n):
            if y < n // 2:
                row += [(230, 200, 40), (40, 160, 220), (220, 60, 60), (60, 180, 90)][x * 4 // n]
            else:
                row += [240, 240, 240] if (x // 2) % 2 == 0 else [20, 20, 20]
        rows.append(row)
    return rows


buf = bytearray()
views, accessors = [], []


def add(data_bytes, target=None):
    while len(buf) % 4:
        buf.append(0)
    off = len(buf)
    buf.extend(data_bytes)
    v = {"buffer": 0, "byteOffset": off, "byteLength": len(data_bytes)}
    if target:
        v["target"] = target
    views.append(v)
    return len(views) - 1


def accessor(values, comps, ctype="f", target=34962):
    fmt = "<" + ctype * (len(values) * comps)
    flat = [c for v in values for c in (v if comps > 1 else [v])]
    view = add(struct.pack(fmt, *flat), target)
    a = {"bufferView": view, "count": len(values),
         "componentType": 5126 if ctype == "f" else 5125,
         "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[comps]}
    if ctype == "f" and comps == 3:
        a["min"] = [min(v[i] for v in values) for i in range(3)]
        a["max"] = [max(v[i] for v in values) for i in range(3)]
    accessors.append(a)
    return len(accessors) - 1


def quad_mesh(corners, normal, uvs, colors=None):
    attrs = {"POSITION": accessor(corners, 3), "NORMAL": accessor([normal] * 4, 3),
             "TEXCOORD_0": accessor(uvs, 2)}
    if colors:
        attrs["COLOR_0"] = accessor(colors, 4)
    idx = accessor([0, 1, 2, 0, 2, 3], 1, "I", 34963)
    return attrs, idx


meshes = []
# Floor.
attrs, idx = quad_mesh([[-2, 0, 2], [2, 0, 2], [2, 0, -2], [-2, 0, -2]], [0, 1, 0],
                       [[0, 4], [4, 4], [4, 0], [0, 0]])
meshes.append({"name": "floor", "primitives": [{"attributes": attrs, "indices": idx, "material": 0}]})
# Cube with vertex colours: 6 faces × 4 vertices.
faces = [((1, 0, 0), (0, 0, -1), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
         ((0, 1, 0), (1, 0, 0), (0, 0, -1)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
         ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (-1, 0, 0), (0, 1, 0))]
pos, nor, col, ind = [], [], [], []
palette = [(1, 0.2, 0.1, 1), (0.1, 0.8, 0.2, 1), (0.2, 0.3, 1, 1), (1, 1, 0.1, 1), (0.9, 0.9, 0.9, 1), (0.8, 0.1, 0.8, 1)]
for f, (n, u, v) in enumerate(faces):
    base = len(pos)
    for su, sv in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
        pos.append([0.5 * (n[i] + su * u[i] + sv * v[i]) for i in range(3)])
        nor.append(list(n))
        shade = 0.75 + 0.25 * (su * sv)
        col.append([palette[f][k] * shade for k in range(3)] + [1.0])
    ind += [base, base + 1, base + 2, base, base + 2, base + 3]
cube_attrs = {"POSITION": accessor(pos, 3), "NORMAL": accessor(nor, 3), "COLOR_0": accessor(col, 4)}
cube_idx = accessor(ind, 1, "I", 34963)
meshes.append({"name": "cube", "primitives": [{"attributes": cube_attrs, "indices": cube_idx, "material": 1}]})
# Card.
attrs, idx = quad_mesh([[-0.3, 0.3, 0], [0.3, 0.3, 0], [0.3, 0.9, 0], [-0.3, 0.9, 0]], [0, 0, 1],
                       [[0, 1], [1, 1], [1, 0], [0, 0]])
meshes.append({"name": "card", "primitives": [{"attributes": attrs, "indices": idx, "material": 2}]})

uri = lambda mime, data: "data:%s;base64,%s" % (mime, base64.b64encode(data).decode())
pitch = math.radians(-15)
yaw = math.radians(30)
doc = {
    "asset": {"version": "2.0", "generator": "tiltfield tools/make_example_gltf.py"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [
        {"name": "floor", "mesh": 0},
        {"name": "cube", "mesh": 1, "translation": [0.4, 0.5, 0.2],
         "rotation": [0, math.sin(yaw / 2), 0, math.cos(yaw / 2)]},
        {"name": "card", "mesh": 2, "translation": [-0.8, 0, -1.0]},
        {"name": "camera", "camera": 0, "translation": [0, 1.2, 4.0],
         "rotation": [math.sin(pitch / 2), 0, 0, math.cos(pitch / 2)]},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "aspectRatio": 1.0}}],
    "meshes": meshes,
    "materials": [
        {"name": "checker", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
        {"name": "painted", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1.0]}},
        {"name": "stripes", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
    ],
    "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 1}],
    "samplers": [{"wrapS": 10497, "wrapT": 10497}, {"wrapS": 33071, "wrapT": 33071}],
    "images": [
        {"uri": uri("image/png", png(16, 16, checker(16, 4, (200, 180, 140), (40, 50, 70))))},
        {"uri": uri("image/png", png(32, 32, stripes(32)))},
    ],
    "accessors": accessors,
    "bufferViews": views,
    "buffers": [{"byteLength": len(buf), "uri": uri("application/octet-stream", bytes(buf))}],
}
out = Path(__file__).resolve().parent.parent / "tests" / "data" / "example.gltf"
out.write_text(json.dumps(doc, indent=1) + "\n")
print("wrote", out)

# Binary glTF: 12-byte header, a JSON chunk padded with spaces, a BIN chunk padded with zeros.
doc["buffers"] = [{"byteLength": len(buf)}]
doc["asset"]["generator"] += " (GLB)"
js = json.dumps(doc).encode()
js += b" " * (-len(js) % 4)
binary = bytes(buf) + b"\x00" * (-len(buf) % 4)
chunks = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + binary
glb = out.with_suffix(".glb")
glb.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks)
print("wrote", glb)
