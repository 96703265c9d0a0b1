#!/usr/bin/env python3
"""Writes the image-quality bench's own scene: what a denoiser finds hardest, in one glTF.

`python3 tools/scripts/quality_scene.py DIR` writes DIR/quality.gltf, quality.bin and detail.png:

- a floor and a back wall with a texture finer than the pixels of a 320 x 200 render (a
  checker of two woods' colours, dark grain lines every 8 texels and speckles);
- a fence of 15 bars 2 cm thick (thin geometry, a few pixels wide at most);
- a glass sphere (KHR_materials_transmission, IOR 1.5) and a rough red ball;
- a camera named Camera (`treelight render quality.gltf --camera Camera`).

The file has no lights: the editor's default sun and the sky light it. The output is the same
on every run (no randomness beyond a fixed-seed generator).
"""

import json
import math
import struct
import sys
import zlib
from pathlib import Path

TEXELS = 512


def png(width, height, rows):
    """An 8-bit RGB PNG of `rows` (bytes of width * 3 each)."""
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(kind, body):
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(raw, 9))
        + chunk(b"IEND", b"")
    )


def detail_texture():
    state = 12345

    def rand():
        nonlocal state
        state = (state * 1103515245 + 12345) & 0x7FFFFFFF
        return state / 0x7FFFFFFF

    rows = []
    for y in range(TEXELS):
        row = bytearray()
        for x in range(TEXELS):
            light = ((x // 32) + (y // 32)) % 2 == 0
            r, g, b = (196, 150, 98) if light else (110, 70, 42)
            if x % 8 == 0 or (y + x // 64) % 13 == 0:
                r, g, b = r // 2, g // 2, b // 2
            if rand() < 0.04:
                r, g, b = 235, 225, 200
            row += bytes((r, g, b))
        rows.append(row)
    return png(TEXELS, TEXELS, rows)


class Mesh:
    """Positions, normals, texture coordinates and indices of one primitive."""

    def __init__(self):
        self.p, self.n, self.uv, self.i = [], [], [], []

    def vertex(self, p, n, uv):
        self.p.append(p)
        self.n.append(n)
        self.uv.append(uv)
        return len(self.p) - 1

    def quad(self, corners, normal, uv_scale):
        base = [self.vertex(c, normal, (u * uv_scale, v * uv_scale))
                for c, (u, v) in zip(corners, [(0, 1), (1, 1), (1, 0), (0, 0)])]
        self.i += [base[0], base[1], base[2], base[0], base[2], base[3]]


def box(mesh, lo, hi):
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [
        ([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], (0, 0, 1)),
        ([(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)], (0, 0, -1)),
        ([(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)], (1, 0, 0)),
        ([(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)], (-1, 0, 0)),
        ([(x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (x0, y1, z0)], (0, 1, 0)),
    ]
    for corners, normal in faces:
        mesh.quad(corners, normal, 1.0)


def sphere(mesh, centre, radius, rings=24, segments=48):
    start = len(mesh.p)
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments + 1):
            phi = 2 * math.pi * s / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            p = tuple(c + radius * k for c, k in zip(centre, n))
            mesh.vertex(p, n, (s / segments, r / rings))
    for r in range(rings):
        for s in range(segments):
            a = start + r * (segments + 1) + s
            b = a + segments + 1
            mesh.i += [a, a + 1, b, a + 1, b + 1, b]


def scene_json_and_bin(meshes):
    """The glTF document and its buffer for `meshes` ((name, Mesh, material index) each)."""
    blob = bytearray()
    views, accessors, gltf_meshes, nodes = [], [], [], []

    def add(data, fmt, count, kind, component, target, bounds=None):
        while len(blob) % 4:
            blob.append(0)
        offset = len(blob)
        for item in data:
            blob.extend(struct.pack(fmt, *item) if isinstance(item, tuple) else struct.pack(fmt, item))
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob) - offset,
                      "target": target})
        accessor = {"bufferView": len(views) - 1, "componentType": component, "count": count,
                    "type": kind}
        if bounds:
            accessor["min"], accessor["max"] = bounds
        accessors.append(accessor)
        return len(accessors) - 1

    for name, mesh, material in meshes:
        lo = [min(p[k] for p in mesh.p) for k in range(3)]
        hi = [max(p[k] for p in mesh.p) for k in range(3)]
        position = add(mesh.p, "<3f", len(mesh.p), "VEC3", 5126, 34962, (lo, hi))
        normal = add(mesh.n, "<3f", len(mesh.n), "VEC3", 5126, 34962)
        uv = add(mesh.uv, "<2f", len(mesh.uv), "VEC2", 5126, 34962)
        indices = add(mesh.i, "<I", len(mesh.i), "SCALAR", 5125, 34963)
        gltf_meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": position, "NORMAL": normal, "TEXCOORD_0": uv},
            "indices": indices, "material": material}]})
        nodes.append({"name": name, "mesh": len(gltf_meshes) - 1})
    eye, target = (0.0, 1.4, 4.2), (0.0, 0.6, 0.0)
    pitch = math.atan2(target[1] - eye[1], eye[2] - target[2])
    nodes.append({"name": "Camera", "camera": 0, "translation": list(eye),
                  "rotation": [math.sin(pitch / 2), 0, 0, math.cos(pitch / 2)]})
    doc = {
        "asset": {"version": "2.0", "generator": "treelight tools/scripts/quality_scene.py"},
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 0.7, "aspectRatio": 1.6, "znear": 0.05}}],
        "meshes": gltf_meshes,
        "materials": [
            {"name": "wood", "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.6}},
            {"name": "bars", "pbrMetallicRoughness": {
                "baseColorFactor": [0.9, 0.9, 0.88, 1], "metallicFactor": 1.0,
                "roughnessFactor": 0.3}},
            {"name": "glass", "pbrMetallicRoughness": {
                "baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                            "KHR_materials_ior": {"ior": 1.5}}},
            {"name": "red", "pbrMetallicRoughness": {
                "baseColorFactor": [0.7, 0.12, 0.08, 1], "metallicFactor": 0.0,
                "roughnessFactor": 0.8}},
        ],
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"wrapS": 10497, "wrapT": 10497, "magFilter": 9729, "minFilter": 9987}],
        "images": [{"uri": "detail.png"}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": "quality.bin", "byteLength": len(blob)}],
    }
    return doc, bytes(blob)


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: quality_scene.py DIR")
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    floor, wall, bars, glass, ball = Mesh(), Mesh(), Mesh(), Mesh(), Mesh()
    floor.quad([(-4, 0, 4), (4, 0, 4), (4, 0, -4), (-4, 0, -4)], (0, 1, 0), 4.0)
    wall.quad([(-4, 0, -3), (4, 0, -3), (4, 4, -3), (-4, 4, -3)], (0, 0, 1), 3.0)
    for k in range(15):
        x = -1.6 + k * 0.22
        box(bars, (x - 0.01, 0.0, -0.81), (x + 0.01, 1.2, -0.79))
    sphere(glass, (0.9, 0.5, 0.6), 0.5)
    sphere(ball, (-1.0, 0.4, 0.8), 0.4)
    doc, blob = scene_json_and_bin(
        [("floor", floor, 0), ("wall", wall, 0), ("fence", bars, 1), ("glass", glass, 2),
         ("ball", ball, 3)])
    (out / "quality.gltf").write_text(json.dumps(doc, indent=1))
    (out / "quality.bin").write_bytes(blob)
    (out / "detail.png").write_bytes(detail_texture())
    print(out / "quality.gltf")


if __name__ == "__main__":
    main()
