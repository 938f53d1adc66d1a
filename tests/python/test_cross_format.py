"""One small scene written as caustica JSON, OBJ, PLY, glTF, GLB and Mitsuba XML renders to the
same image.

The scene is what a mesh file alone gives (the loaders' defaults, load.h): a floor, a box and a
pyramid, grey diffuse 0.5 (OBJ Kd 0.5, PLY's default material, JSON/XML `diffuse` 0.5), lit by a
constant white environment of radiance 1, seen by the default camera (fov 40 degrees down -z at
the bounds' centre). JSON and XML spell all of that out; OBJ and PLY rely on the defaults.
glTF has no Lambertian material, so its group is base colour 0.5 / metallic 0 / roughness 1
compared with the JSON `metallic_roughness` of the same values.

Comparison: same seed for every format; per 8x8 region and channel, the difference of means is
within 4 standard errors, the standard error measured from the spread of the reference's region
means over 6 independent seeds (so the bound is the noise level of one render, not the pixels'
spread). Identical scenes with one seed differ far less than that; a wrong material, light or
camera differs by many standard errors.
"""
import base64
import json
import math
import struct
import warnings

import numpy as np
import pytest

import caustica

RES = 32
SPP = 16


def geometry():
    """Positions and triangle indices (counter-clockwise seen from outside)."""
    P, I = [], []

    def quad(a, b, c, d):
        base = len(P)
        P.extend([a, b, c, d])
        I.extend([base, base + 1, base + 2, base, base + 2, base + 3])

    quad((-2, 0, -2), (-2, 0, 2), (2, 0, 2), (2, 0, -2))  # floor, normal +y
    # A box [0.2, 1.2] x [0, 1] x [-1, 0], normals out.
    x0, x1, y0, y1, z0, z1 = 0.2, 1.2, 0.0, 1.0, -1.0, 0.0
    quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1))  # +z
    quad((x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0))  # -z
    quad((x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1))  # +x
    quad((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0))  # -x
    quad((x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (x0, y1, z0))  # +y
    # A pyramid with apex (-1, 1.5, 0.5) over the square [-1.6, -0.4] x [-0.1, 1.1]; its faces
    # share no vertices, so the smooth normals OBJ computes when a file has none are the faces'.
    sq = [(-1.6, 0, -0.1), (-0.4, 0, -0.1), (-0.4, 0, 1.1), (-1.6, 0, 1.1)]
    for a, b in ((0, 3), (3, 2), (2, 1), (1, 0)):
        base = len(P)
        P.extend([sq[a], sq[b], (-1.0, 1.5, 0.5)])
        I.extend([base, base + 1, base + 2])
    return np.array(P, dtype=np.float32), np.array(I, dtype=np.uint32)


def default_camera(P):
    lo, hi = P.min(axis=0).astype(np.float64), P.max(axis=0).astype(np.float64)
    c = (lo + hi) / 2
    r = 0.5 * np.linalg.norm(hi - lo)
    pos = c + np.array([0, 0, 1.1 * r / math.sin(math.radians(20))])
    return c, pos


def write_obj(d, P, I):
    (d / "s.mtl").write_text("newmtl grey\nKd 0.5 0.5 0.5\nillum 1\n")
    lines = ["mtllib s.mtl", "usemtl grey"] + [f"v {x} {y} {z}" for x, y, z in P]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in I.reshape(-1, 3)]
    (d / "s.obj").write_text("\n".join(lines) + "\n")
    return d / "s.obj"


def write_ply(d, P, I):
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(P)}\nproperty float x\n"
            f"property float y\nproperty float z\nelement face {len(I) // 3}\n"
            "property list uchar uint vertex_indices\nend_header\n").encode()
    body = P.astype("<f4").tobytes()
    for t in I.reshape(-1, 3):
        body += struct.pack("<B3I", 3, *map(int, t))
    (d / "s.ply").write_bytes(head + body)
    return d / "s.ply"


def json_scene(P, I, material, mesh_file=None):
    c, pos = default_camera(P)
    shape = {"type": "mesh", "material": "m"}
    if mesh_file:
        shape["file"] = mesh_file
    else:
        shape.update(positions=P.tolist(), indices=I.tolist())
    return {
        "camera": {"position": pos.tolist(), "target": c.tolist(), "up": [0, 1, 0], "fov": 40, "width": 512,
                   "height": 512},
        "materials": {"m": material},
        "shapes": [shape],
        "lights": [{"type": "environment", "radiance": 1}],
    }


def write_xml(d, P):
    c, pos = default_camera(P)
    v = lambda a: ", ".join(repr(float(x)) for x in a)
    (d / "s.xml").write_text(f"""<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="{v(pos)}" target="{v(c)}" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="512"/><integer name="height" value="512"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="ply"><string name="filename" value="s.ply"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
""")
    return d / "s.xml"


def gltf_doc(P, I, uri=None):
    pos, idx = P.astype("<f4").tobytes(), I.astype("<u4").tobytes()
    buf = pos + idx
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0,
                                                "roughnessFactor": 1}}],
        "buffers": [{"byteLength": len(buf)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(P), "type": "VEC3",
             "min": P.min(axis=0).tolist(), "max": P.max(axis=0).tolist()},
            {"bufferView": 1, "componentType": 5125, "count": len(I), "type": "SCALAR"},
        ],
    }
    if uri:
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    return doc, buf


def write_gltf(d, P, I):
    doc, _ = gltf_doc(P, I, uri=True)
    (d / "s.gltf").write_text(json.dumps(doc))
    return d / "s.gltf"


def write_glb(d, P, I):
    doc, buf = gltf_doc(P, I)
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    buf += b"\0" * (-len(buf) % 4)
    glb = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(buf))
    glb += struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(buf), 0x004E4942) + buf
    (d / "s.glb").write_bytes(glb)
    return d / "s.glb"


def render(scene, seed):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the default camera and light are reported as warnings
        s = caustica.load_scene(str(scene), width=RES, height=RES) if not isinstance(scene, dict) else \
            caustica.load_dict(scene, width=RES, height=RES)
        return caustica.render(s, spp=SPP, seed=seed, max_depth=4)


def region_means(img):
    return img.reshape(RES // 8, 8, RES // 8, 8, 3).mean(axis=(1, 3))


def assert_same(ref_scene, others):
    ref = [region_means(render(ref_scene, seed)) for seed in range(1, 7)]
    se = np.std(ref, axis=0, ddof=1)  # one render's noise per region and channel
    base = ref[0]  # seed 1
    assert base.min() > 0.02, "the scene should be lit everywhere in view"
    for name, scene in others.items():
        img = region_means(render(scene, 1))
        z = np.abs(img - base) / (np.sqrt(2) * se + 1e-6)
        assert z.max() < 4, f"{name}: worst region differs by {z.max():.1f} standard errors"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("xfmt")
    P, I = geometry()
    out = {"P": P, "I": I, "obj": write_obj(d, P, I), "ply": write_ply(d, P, I), "xml": write_xml(d, P),
           "gltf": write_gltf(d, P, I), "glb": write_glb(d, P, I)}
    (d / "s.json").write_text(json.dumps(json_scene(P, I, {"type": "diffuse", "reflectance": 0.5})))
    out["json"] = d / "s.json"
    (d / "file.json").write_text(json.dumps(json_scene(P, I, {"type": "diffuse", "reflectance": 0.5}, "s.ply")))
    out["json_file"] = d / "file.json"
    return out


def test_json_obj_ply_xml_render_alike(files):
    assert_same(files["json"], {k: files[k] for k in ("obj", "ply", "xml", "json_file")})


def test_gltf_glb_render_like_json_metallic_roughness(files):
    mr = {"type": "metallic_roughness", "base_color": 0.5, "metallic": 0, "roughness": 1}
    ref = json_scene(files["P"], files["I"], mr)
    assert_same(ref, {"gltf": files["gltf"], "glb": files["glb"]})


def test_the_comparison_can_fail(files):
    """A different albedo (0.45 instead of 0.5) is caught by the same bound."""
    other = json_scene(files["P"], files["I"], {"type": "diffuse", "reflectance": 0.45})
    with pytest.raises(AssertionError, match="standard errors"):
        assert_same(files["json"], {"albedo 0.45": other})
