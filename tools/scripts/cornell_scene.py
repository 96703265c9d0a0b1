#!/usr/bin/env python3
"""Writes a closed Cornell box as glTF, for comparing the path tracer with Blender's Cycles.

`python3 tools/scripts/cornell_scene.py DIR` writes DIR/cornell.gltf and cornell.bin:

- a room 2 m wide, deep and high, closed on every side (the camera inside, so no ray leaves it and
  neither renderer's sky counts), white walls, a red one on the left and a green one on the right;
- a short and a tall block, white;
- every surface Lambertian: metallic 0, roughness 1 and `KHR_materials_specular` with a specular
  factor and colour of 0 (no glossy lobe: glTF's BRDF is then Lambert's);
- one point light of 100 cd (`KHR_lights_punctual`, no `range`: unlimited) under the ceiling;
- a camera named Camera (`treelight render cornell.gltf --camera Camera`).

The same file on every run.
"""

import json
import struct
import sys
from pathlib import Path

WHITE = [0.8, 0.8, 0.8]
RED = [0.8, 0.05, 0.05]
GREEN = [0.05, 0.8, 0.05]


class Mesh:
    """Triangles of one material: positions and normals, no index sharing."""

    def __init__(self):
        self.positions, self.normals = [], []

    def quad(self, a, b, c, d):
        """Quad a b c d, counter-clockwise seen from the side its normal faces."""
        u = [b[i] - a[i] for i in range(3)]
        v = [d[i] - a[i] for i in range(3)]
        n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
        length = sum(x * x for x in n) ** 0.5
        n = [x / length for x in n]
        for p in (a, b, c, a, c, d):
            self.positions.append(p)
            self.normals.append(n)

    def block(self, lo, hi):
        """An axis-aligned box's five visible faces (its bottom stands on the floor), outward."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        self.quad([x0, y1, z1], [x1, y1, z1], [x1, y1, z0], [x0, y1, z0])  # top
        self.quad([x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1])  # +z
        self.quad([x1, y0, z0], [x0, y0, z0], [x0, y1, z0], [x1, y1, z0])  # -z
        self.quad([x1, y0, z1], [x1, y0, z0], [x1, y1, z0], [x1, y1, z1])  # +x
        self.quad([x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0])  # -x


def room():
    """The meshes by material: the room's faces facing inwards, then the blocks."""
    white, red, green = Mesh(), Mesh(), Mesh()
    lo, hi = -1.0, 1.0
    white.quad([lo, 0, hi], [hi, 0, hi], [hi, 0, lo], [lo, 0, lo])  # floor, up
    white.quad([lo, 2, lo], [hi, 2, lo], [hi, 2, hi], [lo, 2, hi])  # ceiling, down
    white.quad([lo, 0, lo], [hi, 0, lo], [hi, 2, lo], [lo, 2, lo])  # back, +z
    white.quad([hi, 0, hi], [lo, 0, hi], [lo, 2, hi], [hi, 2, hi])  # front (behind the camera), -z
    red.quad([lo, 0, hi], [lo, 0, lo], [lo, 2, lo], [lo, 2, hi])  # left, +x
    green.quad([hi, 0, lo], [hi, 0, hi], [hi, 2, hi], [hi, 2, lo])  # right, -x
    white.block([0.05, 0.0, -0.55], [0.65, 0.6, 0.05])
    white.block([-0.7, 0.0, -0.8], [-0.15, 1.2, -0.25])
    return [("White", WHITE, white), ("Red", RED, red), ("Green", GREEN, green)]


def document():
    """The glTF document and its binary buffer."""
    blob = bytearray()
    views, accessors, meshes, nodes, materials = [], [], [], [], []
    for name, colour, mesh in room():
        ids = []
        for kind, data in (("POSITION", mesh.positions), ("NORMAL", mesh.normals)):
            offset = len(blob)
            for p in data:
                blob += struct.pack("<3f", *p)
            views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob) - offset,
                          "target": 34962})
            accessor = {"bufferView": len(views) - 1, "componentType": 5126, "count": len(data),
                        "type": "VEC3"}
            if kind == "POSITION":
                accessor["min"] = [min(p[i] for p in data) for i in range(3)]
                accessor["max"] = [max(p[i] for p in data) for i in range(3)]
            accessors.append(accessor)
            ids.append(len(accessors) - 1)
        materials.append({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": colour + [1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0.0,
                                                       "specularColorFactor": [0.0, 0.0, 0.0]}}})
        meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": ids[0], "NORMAL": ids[1]},
            "material": len(materials) - 1}]})
        nodes.append({"name": name, "mesh": len(meshes) - 1})
    nodes.append({"name": "Lamp", "translation": [0.0, 1.9, 0.0],
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    nodes.append({"name": "Camera", "camera": 0, "translation": [0.0, 1.0, 0.95]})
    doc = {
        "asset": {"version": "2.0", "generator": "treelight tools/scripts/cornell_scene.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "Lamp", "type": "point", "color": [1.0, 1.0, 1.0], "intensity": 100.0}]}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 1.2, "aspectRatio": 1.6, "znear": 0.01, "zfar": 100.0}}],
        "meshes": meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": "cornell.bin", "byteLength": len(blob)}],
    }
    return doc, bytes(blob)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    doc, blob = document()
    (out / "cornell.bin").write_bytes(blob)
    (out / "cornell.gltf").write_text(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
