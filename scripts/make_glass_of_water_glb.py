#!/usr/bin/env python3
"""Write scenes/glass_of_water.glb: the scene of scenes/glass_of_water_nested.toml
as glTF 2.0, laid out the way Blender's exporter writes it (standard library only).

Nodes with translation/rotation, meshes with POSITION, NORMAL, TEXCOORD_0 and
16-bit indices, materials with pbrMetallicRoughness, KHR_materials_transmission,
KHR_materials_ior, KHR_materials_volume and KHR_materials_emissive_strength, a
perspective camera, and what glTF has no place for in extras (Blender writes
custom properties there): the nested priority as "snell:priority" on the glass
and water materials, and the sky as "snell:environment" on the scene. The key
light is an emissive black quad (glTF has no area lights); the checkered ground
and backdrop are base colour textures written beside the .glb (as Blender's
"glTF Binary" export with external textures). tests/import_gltf.rs renders it
against the TOML.

    python3 scripts/make_glass_of_water_glb.py [OUT_DIR]   (default: scenes/)
"""
import json
import math
import struct
import sys
import zlib
from pathlib import Path

SEGMENTS = 256  # as the TOML's lathe
PX_PER_SQUARE = 16


def lathe(profile, segments):
    """A revolved (r, y) profile: smooth around the axis, sharp at every profile
    joint (each segment has its own vertices), counter-clockwise seen from outside."""
    pos, nrm, uv, idx = [], [], [], []
    for (r0, y0), (r1, y1) in zip(profile, profile[1:]):
        dr, dy = r1 - r0, y1 - y0
        ln = math.hypot(dr, dy)
        nr, ny = dy / ln, -dr / ln  # walking upward on the outside faces out
        base = len(pos)
        for k in range(segments):
            t = 2 * math.pi * k / segments
            c, s = math.cos(t), math.sin(t)
            for r, y in ((r0, y0), (r1, y1)):
                pos.append((r * c, y, r * s))
                nrm.append((nr * c, ny, nr * s))
                uv.append((k / segments, 0.0))
        for k in range(segments):
            a0, a1 = base + 2 * k, base + 2 * k + 1
            b0, b1 = base + 2 * ((k + 1) % segments), base + 2 * ((k + 1) % segments) + 1
            want = (nrm[a0][0] + nrm[b1][0], nrm[a0][1] + nrm[b1][1], nrm[a0][2] + nrm[b1][2])
            if r0 == 0:  # a fan around the axis point a0
                idx.append(oriented(pos, a0, a1, b1, want))
            elif r1 == 0:  # a fan around the axis point a1
                idx.append(oriented(pos, a0, a1, b0, want))
            else:
                idx.append(oriented(pos, a0, a1, b1, want))
                idx.append(oriented(pos, a0, b1, b0, want))
    return pos, nrm, uv, idx


def oriented(pos, a, b, c, want):
    """Triangle (a, b, c) wound so that its normal points along `want`."""
    pa, pb, pc = pos[a], pos[b], pos[c]
    e1 = [pb[i] - pa[i] for i in range(3)]
    e2 = [pc[i] - pa[i] for i in range(3)]
    n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
    return (a, b, c) if sum(n[i] * want[i] for i in range(3)) > 0 else (a, c, b)


def quad(corners, normal, uvs):
    """Two triangles over four corners (in order around the quad), facing `normal`."""
    pos = list(corners)
    nrm = [normal] * 4
    return pos, nrm, list(uvs), [oriented(pos, 0, 1, 2, normal), oriented(pos, 0, 2, 3, normal)]


def srgb8(c):
    c = max(0.0, min(1.0, c))
    s = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return int(round(s * 255))


def checker_png(path, w, h, world_of_pixel, size, color0, color1):
    """An 8-bit sRGB PNG of snell's world-space checker seen through the UV map."""
    c0, c1 = bytes(srgb8(x) for x in color0), bytes(srgb8(x) for x in color1)
    rows = []
    for row in range(h):
        line = bytearray(b"\x00")
        for col in range(w):
            a, b = world_of_pixel((col + 0.5) / w, (row + 0.5) / h)
            line += c0 if (math.floor(a / size) + math.floor(b / size)) % 2 == 0 else c1
        rows.append(bytes(line))
    raw = b"".join(rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"sRGB", b"\x00") + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def look_at_quaternion(eye, target, up):
    """Rotation (x, y, z, w) taking the glTF camera's -Z to target - eye, +Y to up."""
    f = [target[i] - eye[i] for i in range(3)]
    fl = math.sqrt(sum(x * x for x in f))
    f = [x / fl for x in f]
    r = [f[1] * up[2] - f[2] * up[1], f[2] * up[0] - f[0] * up[2], f[0] * up[1] - f[1] * up[0]]
    rl = math.sqrt(sum(x * x for x in r))
    r = [x / rl for x in r]
    u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
    z = [-x for x in f]
    m = [[r[0], u[0], z[0]], [r[1], u[1], z[1]], [r[2], u[2], z[2]]]  # columns right, up, -forward
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s]
    if m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
        return [0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s]
    if m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
        return [(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s]
    s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
    return [(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s]


class Builder:
    def __init__(self):
        self.bin = bytearray()
        self.gltf = {"bufferViews": [], "accessors": [], "meshes": []}

    def view(self, data, target):
        while len(self.bin) % 4:
            self.bin += b"\x00"
        self.gltf["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data), "target": target}
        )
        self.bin += data
        return len(self.gltf["bufferViews"]) - 1

    def accessor(self, rows, kind):
        flat = [x for r in rows for x in r]
        v = self.view(struct.pack(f"<{len(flat)}f", *flat), 34962)
        a = {"bufferView": v, "componentType": 5126, "count": len(rows), "type": kind}
        if kind == "VEC3":
            a["min"] = [min(r[i] for r in rows) for i in range(3)]
            a["max"] = [max(r[i] for r in rows) for i in range(3)]
        self.gltf["accessors"].append(a)
        return len(self.gltf["accessors"]) - 1

    def mesh(self, name, geom, material):
        pos, nrm, uv, tris = geom
        flat = [i for t in tris for i in t]
        fmt, ctype = ("H", 5123) if len(pos) < 65536 else ("I", 5125)
        iv = self.view(struct.pack(f"<{len(flat)}{fmt}", *flat), 34963)
        self.gltf["accessors"].append({"bufferView": iv, "componentType": ctype, "count": len(flat), "type": "SCALAR"})
        ia = len(self.gltf["accessors"]) - 1
        attrs = {"POSITION": self.accessor(pos, "VEC3"), "NORMAL": self.accessor(nrm, "VEC3"),
                 "TEXCOORD_0": self.accessor(uv, "VEC2")}
        self.gltf["meshes"].append({"name": name, "primitives": [{"attributes": attrs, "indices": ia, "material": material}]})
        return len(self.gltf["meshes"]) - 1


def main():
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "scenes"
    b = Builder()
    # Ground: 40 x 40 m at y = -0.01; u along x, v along z (texture rows from z = -20).
    gx = [(-20, -20), (20, -20), (20, 20), (-20, 20)]
    ground = quad([(x, -0.01, z) for x, z in gx], (0.0, 1.0, 0.0), [((x + 20) / 40, (z + 20) / 40) for x, z in gx])
    # Backdrop: 20 x 10 m at z = -2.5 facing +z; its texture spans y from -0.25 to 10
    # (41 squares) so that the squares sit on the world grid (the quad starts at -0.01).
    by = [(-10, -0.01), (10, -0.01), (10, 9.99), (-10, 9.99)]
    backdrop = quad([(x, y, -2.5) for x, y in by], (0.0, 0.0, 1.0), [((x + 10) / 20, (10 - y) / 10.25) for x, y in by])
    key = quad([(x, 0.0, z) for x, z in [(-1.5, -1.5), (1.5, -1.5), (1.5, 1.5), (-1.5, 1.5)]], (0.0, -1.0, 0.0),
               [(0, 0), (1, 0), (1, 1), (0, 1)])
    glass = lathe([(0.0, 0.0), (1.0, 0.0), (1.0, 2.5), (0.9, 2.5), (0.9, 0.1), (0.0, 0.1)], SEGMENTS)
    water = lathe([(0.0, 0.05), (0.95, 0.05), (0.95, 1.8), (0.0, 1.8)], SEGMENTS)
    meshes = [b.mesh("Ground", ground, 0), b.mesh("Backdrop", backdrop, 1), b.mesh("KeyLight", key, 2),
              b.mesh("Glass", glass, 3), b.mesh("Water", water, 4)]
    n = PX_PER_SQUARE
    checker_png(out / "glass_of_water_ground.png", 80 * n, 80 * n, lambda u, v: (-20 + 40 * u, -20 + 40 * v),
                0.5, (0.8, 0.8, 0.8), (0.1, 0.1, 0.1))
    checker_png(out / "glass_of_water_backdrop.png", 80 * n, 41 * n, lambda u, v: (-10 + 20 * u, 10 - 10.25 * v),
                0.25, (0.8, 0.8, 0.8), (0.7, 0.15, 0.1))

    def dielectric(name, ior, priority):
        return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0,
                                                       "roughnessFactor": 0.0},
                "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                               "KHR_materials_ior": {"ior": ior}, "KHR_materials_volume": {"thicknessFactor": 0.1}},
                "extras": {"snell:priority": priority}}

    def textured(name, image):
        return {"name": name, "pbrMetallicRoughness": {"baseColorTexture": {"index": image}, "metallicFactor": 0.0,
                                                       "roughnessFactor": 1.0}}

    g = b.gltf
    g.update({
        "asset": {"version": "2.0", "generator": "snell scripts/make_glass_of_water_glb.py (Blender exporter layout)"},
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                           "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "Scene", "nodes": list(range(6)), "extras": {"snell:environment": [0.3, 0.3, 0.3]}}],
        "nodes": [
            {"name": "Camera", "camera": 0, "translation": [0.0, 3.0, 6.5],
             "rotation": look_at_quaternion((0.0, 3.0, 6.5), (0.0, 1.1, 0.0), (0.0, 1.0, 0.0))},
            {"name": "ground", "mesh": meshes[0]},
            {"name": "backdrop", "mesh": meshes[1]},
            {"name": "key", "mesh": meshes[2], "translation": [1.5, 6.0, 3.0]},
            {"name": "glass", "mesh": meshes[3]},
            {"name": "water", "mesh": meshes[4]},
        ],
        "cameras": [{"name": "Camera", "type": "perspective",
                     "perspective": {"yfov": math.radians(32.0), "aspectRatio": 640 / 480, "znear": 0.01, "zfar": 1000.0}}],
        "materials": [
            textured("GroundChecker", 0),
            textured("BackdropChecker", 1),
            {"name": "KeyLight", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0.0,
                                                          "roughnessFactor": 1.0},
             "emissiveFactor": [1.0, 1.0, 1.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6.0}}},
            dielectric("Glass", 1.5, 2),
            dielectric("Water", 1.33, 1),
        ],
        "textures": [{"source": 0}, {"source": 1}],
        "images": [{"uri": "glass_of_water_ground.png"}, {"uri": "glass_of_water_backdrop.png"}],
        "buffers": [{"byteLength": len(b.bin)}],
    })
    js = json.dumps(g, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    binary = bytes(b.bin) + b"\x00" * (-len(b.bin) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    glb = struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(js), b"JSON") + js
    glb += struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    (out / "glass_of_water.glb").write_bytes(glb)
    print(f"wrote {out / 'glass_of_water.glb'} ({len(glb)} bytes) and its two textures")


if __name__ == "__main__":
    main()
