#!/usr/bin/env python3
"""Writes the fuzzer's seed corpus (tests/fuzz/corpus): one small valid file
per scene format, each using the features its loader parses (materials,
textures, transforms, lights, cameras), so mutations reach deep code paths.
Run it again after changing a seed (with the venv's Python, which has Pillow for the WebP seed:
.venv/bin/python tests/fuzz/make_corpus.py); the files are committed. The Draco and meshopt seeds are encoded by
DracoPy and meshoptimizer's Python bindings (pip install DracoPy==2.2.0 meshoptimizer==0.2.30a0), which only
this script needs."""
import base64
import json
import struct
import sys
import zlib
from pathlib import Path

OUT = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent / "corpus")


def glb(doc, binary):
    """A GLB file: the JSON chunk and the BIN chunk (both padded to 4 bytes)."""
    js = json.dumps(doc).encode()
    js += b" " * ((4 - len(js) % 4) % 4)
    binary += b"\0" * ((4 - len(binary) % 4) % 4)
    out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(binary))
    return out + struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(binary), 0x004E4942) + binary


def compressed_seeds():
    """A 4 x 4 vertex grid (positions, normals, UVs; 18 triangles) under an emissive material and a camera, as
    a GLB whose primitive is Draco-compressed (KHR_draco_mesh_compression) and as one whose buffer views are
    meshopt-compressed (EXT_meshopt_compression: attributes and triangle indices), so that mutations reach both
    decoders and the loader's checks of what they return."""
    try:
        import DracoPy
        import meshoptimizer
        import numpy as np
    except ImportError as e:
        print(f"make_corpus.py: no {e.name}: draco.glb and meshopt.glb are left as they are (pip install "
              "DracoPy==2.2.0 meshoptimizer==0.2.30a0 numpy to write them)", file=sys.stderr)
        return
    n = 4
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    u, v = (jj.ravel() / (n - 1)).astype(np.float32), (ii.ravel() / (n - 1)).astype(np.float32)
    pos = np.stack([2 * u - 1, 1 - 2 * v, 0.1 * np.sin(3 * u)], axis=1).astype(np.float32)
    nor = np.tile(np.float32([0, 0, 1]), (n * n, 1))
    uv = np.stack([u, v], axis=1).astype(np.float32)
    tris = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            tris += [a, c, b, b, c, d]
    tris = np.array(tris, np.uint32)

    def doc(prim_ext, accessors, views, buffers, used):
        return {
            "asset": {"version": "2.0"}, "extensionsUsed": used, "extensionsRequired": used,
            "scene": 0, "scenes": [{"nodes": [0, 1]}],
            "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 4]}],
            "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
            "materials": [{"emissiveFactor": [1, 0.5, 0.25]}],
            "meshes": [{"primitives": [dict({"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                             "indices": 3, "material": 0}, **prim_ext)]}],
            "accessors": accessors, "bufferViews": views, "buffers": buffers,
        }

    def accessor(view, ctype, count, type_, **kw):
        a = dict({"componentType": ctype, "count": count, "type": type_}, **kw)
        if view is not None:
            a["bufferView"] = view
        return a

    bounds = {"min": pos.min(axis=0).tolist(), "max": pos.max(axis=0).tolist()}
    # Draco: the accessors give types and counts only; the attribute ids are those DracoPy 2.2.0's encoder gives
    # (texture coordinates 0, normals 1, positions 2: found by loading each assignment).
    draco = DracoPy.encode(pos, tris.reshape(-1, 3), quantization_bits=14, tex_coord=uv.astype(float),
                           normals=nor.astype(float), preserve_order=True)
    d = doc({"extensions": {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {
                "POSITION": 2, "TEXCOORD_0": 0, "NORMAL": 1}}}},
            [accessor(None, 5126, n * n, "VEC3", **bounds), accessor(None, 5126, n * n, "VEC3"),
             accessor(None, 5126, n * n, "VEC2"), accessor(None, 5125, len(tris), "SCALAR")],
            [{"buffer": 0, "byteOffset": 0, "byteLength": len(draco)}], [{"byteLength": len(draco)}],
            ["KHR_draco_mesh_compression"])
    (OUT / "draco.glb").write_bytes(glb(d, draco))
    # meshopt: buffer 0 (the BIN chunk) holds the compressed views, buffer 1 is the fallback (no data).
    meshoptimizer.encode_vertex_version(0)  # the version EXT_meshopt_compression specifies (and Debian's decoder reads)
    parts, views, off = [], [], 0
    for data, stride, count, mode in ((pos, 12, n * n, "ATTRIBUTES"), (nor, 12, n * n, "ATTRIBUTES"),
                                      (uv, 8, n * n, "ATTRIBUTES"), (tris, 4, len(tris), "TRIANGLES")):
        enc = (meshoptimizer.encode_index_buffer(tris, len(tris), n * n) if mode == "TRIANGLES"
               else meshoptimizer.encode_vertex_buffer(np.ascontiguousarray(data), count, stride))
        views.append({"buffer": 1, "byteLength": stride * count, "byteStride": stride,
                      "extensions": {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": off, "byteLength": len(enc),
                                                                 "byteStride": stride, "count": count, "mode": mode}}})
        if mode == "TRIANGLES":
            del views[-1]["byteStride"]
        enc += b"\0" * ((4 - len(enc) % 4) % 4)  # the next view aligned; byteLength is the data's exact size
        parts.append(enc)
        off += len(enc)
    binary = b"".join(parts)
    d = doc({}, [accessor(0, 5126, n * n, "VEC3", **bounds), accessor(1, 5126, n * n, "VEC3"),
                 accessor(2, 5126, n * n, "VEC2"), accessor(3, 5125, len(tris), "SCALAR")],
            views, [{"byteLength": len(binary)},
                    {"byteLength": max(v["byteLength"] for v in views),
                     "extensions": {"EXT_meshopt_compression": {"fallback": True}}}],
            ["EXT_meshopt_compression"])
    (OUT / "meshopt.glb").write_bytes(glb(d, binary))


def png(w, h, rgb):
    """A minimal 8-bit RGB PNG (no filter) from a flat list of (r, g, b)."""
    raw = b"".join(b"\0" + bytes(v for px in rgb[y * w:(y + 1) * w] for v in px) for y in range(h))

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


TEX = png(2, 2, [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255)])


def vol(nx, ny, nz, channels, values):
    """A Mitsuba .vol grid (scene/volume_io.h): header, then float32 samples, x fastest, channels innermost."""
    return (b"VOL" + bytes([3]) + struct.pack("<5i", 1, nx, ny, nz, channels) + struct.pack("<6f", 0, 0, 0, 1, 1, 1)
            + struct.pack(f"<{len(values)}f", *values))


def serialized(meshes):
    """Mitsuba's serialized format (scene/loaders/serialized_loader.cpp), version 4: per mesh a header and a zlib
    stream (flags, name, counts, positions, normals, UVs, colours, indices), then the offsets and the count."""
    out, offsets = b"", []
    for name, pos, nor, uv, col, idx in meshes:
        flags = 0x1000 | (1 if nor else 0) | (2 if uv else 0) | (8 if col else 0)
        body = struct.pack("<I", flags) + name.encode() + b"\0" + struct.pack("<QQ", len(pos) // 3, len(idx) // 3)
        for a in (pos, nor, uv, col):
            if a:
                body += struct.pack(f"<{len(a)}f", *a)
        body += struct.pack(f"<{len(idx)}I", *idx)
        offsets.append(len(out))
        out += struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    return out + b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(meshes))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    # Two meshes: a triangle, and a quad with normals, UVs and colours (the fuzzer loads the second).
    (OUT / "mesh.serialized").write_bytes(serialized([
        ("tri", [0, 0, 0, 1, 0, 0, 0, 1, 0], None, None, None, [0, 1, 2]),
        ("quad", [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0], [0, 0, 1] * 4, [0, 0, 1, 0, 1, 1, 0, 1],
         [1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1], [0, 1, 2, 0, 2, 3])]))
    (OUT / "checker.png").write_bytes(TEX)
    (OUT / "grid.vol").write_bytes(vol(2, 2, 2, 1, [0, 1, 2, 0.5, 1, 3, 0.25, 0]))
    (OUT / "albedo.vol").write_bytes(vol(2, 1, 1, 3, [0.9, 0.8, 0.7, 0.3, 0.6, 0.95]))

    # caustica JSON
    scene = {
        "name": "fuzz",
        "camera": {"position": [0, 1, 5], "target": [0, 1, 0], "up": [0, 1, 0], "fov": 40, "width": 16, "height": 12,
                   "medium": "fog", "near_clip": 0.5, "far_clip": 50, "principal_point": [0.05, -0.1]},
        "film": {"width": 16, "height": 12, "crop": [2, 1, 10, 8]},
        "media": {"fog": {"sigma_a": 0.01, "sigma_s": 0.05, "g": 0.3},
                  "milk": {"sigma_t": [1, 2, 3], "albedo": 0.9, "scale": 2},
                  "smoke": {"type": "heterogeneous", "sigma_t": 2, "albedo": 0.9, "g": 0.2,
                            "density": {"resolution": [2, 2, 2], "values": [0, 1, 2, 0.5, 1, 3, 0.25, 0]},
                            "bounds": [[-1, 0, -1], [1, 2, 1]], "filter": "nearest", "outside": "clamp"},
                  "tinted": {"type": "heterogeneous", "sigma_t": [1, 1.5, 2],
                             "density": {"resolution": [1, 2, 1], "channels": 3, "values": [0, 1, 2, 0.5, 0.25, 1]},
                             "albedo": {"file": "albedo.vol", "transform": {"scale": 2}},
                             "emission": {"resolution": [1, 1, 2], "values": [0, 4], "filter": "nearest"}},
                  "glow": {"sigma_a": [0.5, 0.2, 0.1], "sigma_s": 0.1, "emission": [2, 1, 0.5]}},
        "filter": {"type": "mitchell", "B": 0.25, "C": 0.375, "radius": 2.5},
        "max_depth": 6,
        "materials": {
            "white": {"type": "diffuse", "reflectance": 0.8},
            "gold": {"type": "conductor", "eta": [0.143, 0.374, 1.442], "k": [3.983, 2.385, 1.603], "roughness": 0.2},
            "glass": {"type": "dielectric", "eta": 1.5},
            "plastic": {"type": "plastic", "diffuse": [0.2, 0.4, 0.6]},
            "bound": {"type": "null"},
            "disney": {"type": "principled", "base_color": [0.8, 0.3, 0.2], "metallic": 0.2, "roughness": 0.4,
                       "anisotropic": 0.3, "spec_trans": 0.1, "sheen": 0.5, "clearcoat": 0.6},
            "paint": {"type": "metallic_roughness", "base_color": [0.6, 0.1, 0.1], "roughness": 0.5,
                      "clearcoat": 0.9, "clearcoat_roughness": 0.1, "specular": 0.5, "specular_color": [1, 0.8, 0.6],
                      "sheen_color": [0.7, 0.7, 0.9], "sheen_roughness": 0.3, "transmission": 0.2,
                      "iridescence": 0.5, "iridescence_eta": 1.4, "iridescence_thickness": {"texture": "checker.png", "scale": 500},
                      "iridescence_thickness_min": 150, "clearcoat_normal_map": {"texture": "checker.png", "scale": 0.8},
                      "diffuse_transmission": {"texture": "checker.png", "scale": 0.3},
                      "diffuse_transmission_color": [0.9, 0.7, 0.5]},
        },
        "shapes": [
            {"type": "rectangle", "material": "white", "transform": {"scale": 10, "rotate": {"axis": [1, 0, 0], "angle": -90}}},
            {"type": "sphere", "center": [0, 1, 0], "radius": 1, "material": "glass", "interior": "milk", "exterior": "fog"},
            {"type": "cube", "material": "bound", "interior": "fog", "exterior": None, "transform": {"scale": 20}},
            {"type": "cube", "material": "gold", "transform": {"scale": 0.3, "translate": [1.5, 0.3, 0]}},
            {"type": "sphere", "center": [-1.5, 0.3, 0], "radius": 0.3, "material": "disney"},
            {"type": "mesh", "material": "plastic", "positions": [[-2, 0, 0], [-1, 0, 0], [-1, 1, 0]], "indices": [0, 1, 2]},
            {"type": "sphere", "center": [2.5, 0.3, 0], "radius": 0.3, "material": "paint"},
            {"type": "disk", "material": "white", "emission": [10, 10, 10],
             "transform": {"scale": 0.5, "rotate": {"axis": [1, 0, 0], "angle": 90}, "translate": [0, 4, 0]}},
        ],
        "lights": [{"type": "point", "position": [0, 3, 2], "intensity": 5},
                   {"type": "environment", "radiance": 0.1}],
    }
    (OUT / "scene.json").write_text(json.dumps(scene, indent=1))

    # OBJ + MTL: two groups, a quad, textures, an emitter, normals and uvs, the PBR extension, vertex colours
    # (`v x y z r g b` and an #MRGB run).
    (OUT / "mesh.mtl").write_text(
        "newmtl red\nKd 0.8 0.1 0.1\nmap_Kd checker.png\n"
        "newmtl shiny\nKd 0.2 0.2 0.2\nKs 0.5 0.5 0.5\nNs 200\nillum 2\n"
        "newmtl glass\nKs 1 1 1\nNi 1.5\nd 0.1\nTf 0.9 0.9 0.9\nillum 7\n"
        "newmtl lamp\nKd 0 0 0\nKe 5 5 5\n"
        "newmtl metal\nKd 0.9 0.6 0.2\nPr 0.3\nPm 1\nPc 0.5\nPcr 0.1\nmap_Pr checker.png\nmap_Pm checker.png\n")
    (OUT / "mesh.obj").write_text(
        "mtllib mesh.mtl\n"
        "v -1 0 -1 1 0 0\nv 1 0 -1 0 1 0\nv 1 0 1 0 0 1\nv -1 0 1 1 1 1\nv 0 1 0\n"
        "v -0.2 2 -0.2\nv 0.2 2 -0.2\nv 0.2 2 0.2\nv -0.2 2 0.2\n#MRGB ff808080ff404040\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\n"
        "g floor\nusemtl red\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
        "g pyramid\nusemtl shiny\nf 1 2 5\nusemtl metal\nf 2 3 5\nusemtl glass\nf 3 4 5\nf 4 1 5\n"
        "o lamp\nusemtl lamp\nf 9 8 7 6\n")

    # PLY, ASCII and binary little-endian: a quad with normals and uvs, a triangle.
    verts = [(-1, 0, -1, 0, 1, 0, 0, 0), (1, 0, -1, 0, 1, 0, 1, 0), (1, 0, 1, 0, 1, 0, 1, 1),
             (-1, 0, 1, 0, 1, 0, 0, 1), (0, 1, 0, 0, 1, 0, 0.5, 0.5)]
    faces = [(0, 1, 2, 3), (0, 1, 4)]
    header = ("ply\nformat {fmt} 1.0\ncomment caustica fuzz seed\nelement vertex 5\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
              "element face 2\nproperty list uchar int vertex_indices\nend_header\n")
    body = "".join(" ".join(str(x) for x in v) + "\n" for v in verts)
    body += "".join(f"{len(f)} " + " ".join(str(i) for i in f) + "\n" for f in faces)
    (OUT / "mesh_ascii.ply").write_text(header.format(fmt="ascii") + body)
    b = header.format(fmt="binary_little_endian").encode()
    for v in verts:
        b += struct.pack("<8f", *v)
    for f in faces:
        b += struct.pack("<B", len(f)) + struct.pack(f"<{len(f)}i", *f)
    (OUT / "mesh_binary.ply").write_bytes(b)
    # Binary PLY with face colours (each face record then holds more than its index list).
    b = header.format(fmt="binary_little_endian").replace(
        "vertex_indices\n", "vertex_indices\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n").encode()
    for v in verts:
        b += struct.pack("<8f", *v)
    for f, c in zip(faces, [(255, 128, 0), (0, 64, 255)]):
        b += struct.pack("<B", len(f)) + struct.pack(f"<{len(f)}i", *f) + bytes(c)
    (OUT / "mesh_faces.ply").write_bytes(b)

    # glTF: a textured quad instanced twice under a transformed parent, an
    # emissive triangle, a point light, a camera; .gltf with a data-URI buffer
    # and an external image, and a .glb with everything embedded.
    pos = struct.pack("<12f", -1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0)
    uv = struct.pack("<8f", 0, 1, 1, 1, 1, 0, 0, 0)
    idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    tri = struct.pack("<9f", 0, 2, 0, 1, 2, 0, 0, 3, 0)
    buf = pos + uv + idx + b"\0\0" + tri

    def gltf(buffer_uri, image):
        off_uv, off_idx, off_tri = len(pos), len(pos) + len(uv), len(pos) + len(uv) + len(idx) + 2
        return {
            "asset": {"version": "2.0"},
            "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_clearcoat",
                               "KHR_materials_specular", "KHR_materials_sheen", "KHR_materials_iridescence",
                               "KHR_materials_variants", "KHR_node_visibility", "KHR_materials_diffuse_transmission"],
            "scene": 0,
            "scenes": [{"nodes": [0, 3, 4]}],
            "nodes": [
                {"children": [1, 2], "translation": [0, 1, 0], "rotation": [0, 0.3826834, 0, 0.9238795], "scale": [2, 2, 2]},
                {"mesh": 0},
                {"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 0, 0, 1],
                 "extensions": {"KHR_node_visibility": {"visible": True}}},
                {"mesh": 1},
                {"camera": 0, "translation": [0, 1, 8], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            ],
            "meshes": [
                {"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0,
                                 "extensions": {"KHR_materials_variants": {"mappings": [
                                     {"material": 1, "variants": [0]}]}}}]},
                {"primitives": [{"attributes": {"POSITION": 3}, "material": 1}]},
            ],
            "materials": [
                {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.2, "roughnessFactor": 0.5},
                 "doubleSided": True,
                 "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 0.7, "clearcoatRoughnessFactor": 0.2,
                                                            "clearcoatTexture": {"index": 0},
                                                            "clearcoatNormalTexture": {"index": 0, "scale": 0.5}},
                                "KHR_materials_specular": {"specularFactor": 0.6, "specularColorFactor": [1.2, 1, 0.5],
                                                           "specularTexture": {"index": 0}},
                                "KHR_materials_sheen": {"sheenColorFactor": [0.8, 0.5, 0.6], "sheenRoughnessFactor": 0.4,
                                                        "sheenRoughnessTexture": {"index": 0}},
                                "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 0.4,
                                                                       "diffuseTransmissionColorFactor": [0.9, 0.8, 0.3],
                                                                       "diffuseTransmissionTexture": {"index": 0}},
                                "KHR_materials_iridescence": {"iridescenceFactor": 0.8, "iridescenceIor": 1.5,
                                                              "iridescenceThicknessMaximum": 600,
                                                              "iridescenceThicknessTexture": {"index": 0}}}},
                {"emissiveFactor": [1, 0.8, 0.6], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}},
            ],
            "textures": [{"source": 0, "sampler": 0}],
            "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 10497}],
            "images": [image],
            "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "aspectRatio": 1.5, "znear": 0.1, "zfar": 100}}],
            "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 20, "color": [1, 1, 1]}]},
                           "KHR_materials_variants": {"variants": [{"name": "emissive"}]}},
            "buffers": [dict({"byteLength": len(buffer_uri[1])}, **({"uri": buffer_uri[0]} if buffer_uri[0] else {}))],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                {"buffer": 0, "byteOffset": off_uv, "byteLength": len(uv)},
                {"buffer": 0, "byteOffset": off_idx, "byteLength": len(idx), "target": 34963},
                {"buffer": 0, "byteOffset": off_tri, "byteLength": len(tri)},
            ] + ([{"buffer": 0, "byteOffset": len(buffer_uri[1]) - len(TEX), "byteLength": len(TEX)}]
                 if not buffer_uri[0] else []),
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
                {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 2, 0], "max": [1, 3, 0]},
            ],
        }

    uri = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    (OUT / "scene.gltf").write_text(json.dumps(gltf((uri, buf), {"uri": "checker.png"}), indent=1))
    glb_bin = buf + b"\0" * ((4 - len(buf) % 4) % 4) + TEX
    glb_bin += b"\0" * ((4 - len(glb_bin) % 4) % 4)
    doc = gltf((None, glb_bin), {"bufferView": 4, "mimeType": "image/png"})
    doc["bufferViews"][4]["byteOffset"] = len(buf) + (4 - len(buf) % 4) % 4
    (OUT / "scene.glb").write_bytes(glb(doc, glb_bin))

    # A GLB whose quad's texture is an embedded lossless WebP (EXT_texture_webp, no PNG fallback), so that
    # mutations reach the WebP decoder and the image's size checks.
    import io
    from PIL import Image
    webp = io.BytesIO()
    Image.frombytes("RGB", (2, 2), bytes(v for px in [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255)] for v in px)
                    ).save(webp, format="WEBP", lossless=True)
    webp = webp.getvalue()
    wbin = pos + uv + idx + b"\0\0" + webp
    wbin += b"\0" * ((4 - len(wbin) % 4) % 4)
    wdoc = {
        "asset": {"version": "2.0"}, "extensionsUsed": ["EXT_texture_webp"], "extensionsRequired": ["EXT_texture_webp"],
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"extensions": {"EXT_texture_webp": {"source": 0}}}],
        "images": [{"bufferView": 3, "mimeType": "image/webp"}],
        "buffers": [{"byteLength": len(wbin)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(uv)},
                        {"buffer": 0, "byteOffset": len(pos) + len(uv), "byteLength": len(idx)},
                        {"buffer": 0, "byteOffset": len(pos) + len(uv) + len(idx) + 2, "byteLength": len(webp)}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }
    (OUT / "webp.glb").write_bytes(glb(wdoc, wbin))

    # Mitsuba 3 XML: defaults and $params, ref, twosided, shapes of each kind, emitters, sensor.
    (OUT / "scene.xml").write_text("""<scene version="3.0.0">
  <default name="spp" value="16"/>
  <default name="res" value="16"/>
  <integrator type="volpath"><integer name="max_depth" value="6"/></integrator>
  <medium type="homogeneous" id="fog"><rgb name="sigma_t" value="0.1, 0.2, 0.3"/><float name="albedo" value="0.8"/>
    <phase type="hg"><float name="g" value="0.5"/></phase></medium>
  <medium type="heterogeneous" id="smoke"><float name="scale" value="2"/><rgb name="albedo" value="0.9, 0.8, 0.7"/>
    <volume name="sigma_t" type="gridvolume"><string name="filename" value="grid.vol"/>
      <transform name="to_world"><scale value="2"/><translate x="-1" y="0" z="-1"/></transform></volume></medium>
  <medium type="homogeneous" id="tinted"><float name="sigma_t" value="0.5"/>
    <volume name="albedo" type="gridvolume"><string name="filename" value="albedo.vol"/>
      <string name="filter_type" value="nearest"/></volume></medium>
  <sensor type="perspective">
    <ref id="fog"/>
    <float name="fov" value="40"/><float name="near_clip" value="0.5"/><float name="far_clip" value="50"/>
    <float name="principal_point_offset_x" value="0.05"/>
    <transform name="to_world"><lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/>
      <integer name="crop_offset_x" value="1"/><integer name="crop_width" value="4"/>
      <rfilter type="lanczos"><integer name="lobes" value="2"/></rfilter></film>
  </sensor>
  <bsdf type="twosided" id="white"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf></bsdf>
  <bsdf type="roughconductor" id="gold"><string name="material" value="Au"/><float name="alpha" value="0.2"/></bsdf>
  <bsdf type="dielectric" id="glass"><float name="int_ior" value="1.5"/></bsdf>
  <bsdf type="plastic" id="plastic"><rgb name="diffuse_reflectance" value="0.2, 0.4, 0.6"/></bsdf>
  <bsdf type="diffuse" id="tex"><texture type="bitmap" name="reflectance"><string name="filename" value="checker.png"/></texture></bsdf>
  <shape type="rectangle"><transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform><ref id="white"/></shape>
  <shape type="sphere"><point name="center" x="0" y="1" z="0"/><float name="radius" value="1"/><ref id="glass"/>
    <medium type="homogeneous" name="interior"><rgb name="sigma_t" value="1, 2, 3"/></medium>
    <ref name="exterior" id="fog"/></shape>
  <shape type="cube"><transform name="to_world"><scale value="20"/></transform><bsdf type="null"/>
    <ref name="interior" id="fog"/></shape>
  <shape type="cube"><transform name="to_world"><scale value="0.3"/><translate x="1.5" y="0.3" z="0"/></transform><ref id="gold"/></shape>
  <shape type="obj"><string name="filename" value="mesh.obj"/><ref id="plastic"/></shape>
  <shape type="ply"><string name="filename" value="mesh_binary.ply"/>
    <transform name="to_world"><matrix value="1 0 0 -2  0 1 0 0  0 0 1 0  0 0 0 1"/></transform><ref id="tex"/></shape>
  <shape type="disk">
    <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="4"/></transform>
    <emitter type="area"><rgb name="radiance" value="10, 10, 10"/></emitter>
  </shape>
  <emitter type="point"><point name="position" x="0" y="3" z="2"/><rgb name="intensity" value="5"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
</scene>
""")

    # Mitsuba 3 XML spectra: pairs, a .spd file, single values on emitters, a blackbody.
    (OUT / "green.spd").write_text("# wavelength value\n400 0.05\n550 0.6  # peak\n\n700 0.1\n")
    (OUT / "spectra.xml").write_text("""<scene version="3.0.0">
  <bsdf type="diffuse" id="floor"><spectrum name="reflectance" value="400:0.2, 500:0.7, 700:0.5"/></bsdf>
  <bsdf type="roughconductor" id="metal"><spectrum name="eta" value="400:1.5, 600:0.3, 700:0.2"/>
    <spectrum name="k" value="400:1.9, 700:3.9"/></bsdf>
  <shape type="rectangle"><transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/></transform><ref id="floor"/></shape>
  <shape type="sphere"><ref id="metal"/></shape>
  <shape type="sphere"><point name="center" x="-2"/><bsdf type="principled"><rgb name="base_color" value="0.2, 0.5, 0.8"/>
    <float name="metallic" value="0.3"/><float name="sheen" value="0.4"/><float name="clearcoat" value="0.7"/>
    <float name="spec_trans" value="0.2"/><float name="specular" value="0.6"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="4"/><bsdf type="roughplastic"><float name="alpha" value="0.2"/>
    <rgb name="diffuse_reflectance" value="0.4, 0.2, 0.1"/></bsdf></shape>
  <shape type="cube"><transform name="to_world"><translate x="2"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" filename="green.spd"/></bsdf></shape>
  <shape type="disk"><transform name="to_world"><rotate x="1" angle="90"/><translate y="4"/></transform>
    <emitter type="area"><spectrum name="radiance" value="400:4, 550:9, 700:12"/></emitter></shape>
  <emitter type="point"><point name="position" x="0" y="3" z="2"/><spectrum name="intensity" value="5"/></emitter>
  <emitter type="constant"><spectrum name="radiance" type="blackbody"><float name="temperature" value="6500"/></spectrum>
  </emitter>
</scene>
""")

    compressed_seeds()


if __name__ == "__main__":
    main()
