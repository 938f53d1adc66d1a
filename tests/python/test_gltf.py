"""glTF 2.0 / GLB scenes, built here from Python (JSON + struct-packed buffers,
PNG images from a small zlib encoder), loaded and rendered through the API and
the command line."""
import base64
import json
import math
import os
import struct
import subprocess
import warnings
import zlib

import numpy as np
import pytest

import caustica
from conftest import BIN, srgb_to_linear


# ----------------------------------------------------------------- helpers ---

def png_bytes(rgb):
    """An 8-bit RGB (or RGBA) PNG from an (h, w, 3) (or (h, w, 4)) uint8 array (filter 0 on every row)."""
    rgb = np.asarray(rgb, np.uint8)
    h, w, channels = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6 if channels == 4 else 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


class Gltf:
    """A glTF document with one binary buffer."""

    def __init__(self):
        self.doc = {"asset": {"version": "2.0"}}
        self.bin = bytearray()

    def add(self, key, obj):
        self.doc.setdefault(key, []).append(obj)
        return len(self.doc[key]) - 1

    def view(self, data):
        while len(self.bin) % 4:
            self.bin.append(0)
        off = len(self.bin)
        self.bin += data
        return self.add("bufferViews", {"buffer": 0, "byteOffset": off, "byteLength": len(data)})

    def accessor(self, values, type_, fmt="f", component=5126):
        values = list(values)
        comps = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[type_]
        bv = self.view(struct.pack("<%d%s" % (len(values), fmt), *values))
        return self.add("accessors", {"bufferView": bv, "componentType": component,
                                      "count": len(values) // comps, "type": type_})

    def quad(self, material=None, half=1.0, z=0.0, facing_down=False):
        """A square [-half, half]^2 at height z facing +z (or -z); glTF UVs (v = 0 at the image top)."""
        h = half
        pos = self.accessor([-h, -h, z, h, -h, z, h, h, z, -h, h, z], "VEC3")
        nor = self.accessor([0, 0, -1 if facing_down else 1] * 4, "VEC3")
        uv = self.accessor([0, 1, 1, 1, 1, 0, 0, 0], "VEC2")
        ind = self.accessor([0, 2, 1, 0, 3, 2] if facing_down else [0, 1, 2, 0, 2, 3], "SCALAR", "H", 5123)
        prim = {"attributes": {"POSITION": pos, "NORMAL": nor, "TEXCOORD_0": uv}, "indices": ind}
        if material is not None:
            prim["material"] = material
        return self.add("meshes", {"primitives": [prim]})

    def camera(self, z, yfov, name=None, aspect=1.0):
        cam = {"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01, "aspectRatio": aspect}}
        if name:
            cam["name"] = name
        c = self.add("cameras", cam)
        return self.add("nodes", {"camera": c, "translation": [0, 0, z]})

    def scene(self, nodes):
        self.doc["scenes"] = [{"nodes": nodes}]
        self.doc["scene"] = 0

    def image_data_uri(self, png):
        return self.add("images", {"uri": "data:image/png;base64," + base64.b64encode(png).decode()})

    def image_embedded(self, png):
        return self.add("images", {"bufferView": self.view(png), "mimeType": "image/png"})

    def write(self, path, mode="bin"):
        """mode: 'bin' (NAME.bin next to the .gltf), 'datauri', or 'glb'."""
        path = str(path)
        if self.bin:
            if mode == "bin":
                binname = os.path.splitext(os.path.basename(path))[0] + ".bin"
                with open(os.path.join(os.path.dirname(path), binname), "wb") as f:
                    f.write(self.bin)
                self.doc["buffers"] = [{"uri": binname, "byteLength": len(self.bin)}]
            elif mode == "datauri":
                self.doc["buffers"] = [{"uri": "data:application/octet-stream;base64," +
                                        base64.b64encode(bytes(self.bin)).decode(), "byteLength": len(self.bin)}]
            else:
                self.doc["buffers"] = [{"byteLength": len(self.bin)}]
        if mode != "glb":
            with open(path, "w") as f:
                json.dump(self.doc, f, indent=1)
            return path
        js = json.dumps(self.doc).encode()
        js += b" " * (-len(js) % 4)
        binc = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        body = struct.pack("<II", len(js), 0x4E4F534A) + js
        if binc:
            body += struct.pack("<II", len(binc), 0x004E4942) + binc
        with open(path, "wb") as f:
            f.write(b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
        return path


# A camera at height 3 whose vertical field of view exactly spans the quad [-1, 1]^2.
FILL_FOV = 2 * math.atan(1 / 3)
TEXELS = np.array([[[200, 30, 10], [20, 180, 40]],
                   [[10, 60, 220], [250, 250, 120]]], np.uint8)  # top row, bottom row


def render(path, size=32, spp=4, **kw):
    s = caustica.load_scene(path, width=size, height=size)
    return caustica.render(s, spp=spp, **kw)


def quadrant_centres(img):
    h, w, _ = img.shape
    return {(r, c): img[h // 4 + r * h // 2, w // 4 + c * w // 2] for r in (0, 1) for c in (0, 1)}


# ------------------------------------------------------------------- tests ---

@pytest.mark.parametrize("mode", ["bin", "datauri", "glb"])
def test_emission_texture_texels_render_exactly(tmp_path, mode):
    """A quad with a 2x2 nearest-filtered emission texture, seen head-on and filling the
    image: each quadrant shows its texel (sRGB decoded) exactly (direct emission is
    noise-free). Also checks the v flip: the texture's top row is at the image top."""
    g = Gltf()
    png = png_bytes(TEXELS)
    img = g.image_embedded(png) if mode == "glb" else g.image_data_uri(png)
    g.add("samplers", {"magFilter": 9728, "minFilter": 9728})
    g.add("textures", {"source": img, "sampler": 0})
    mat = g.add("materials", {"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0},
                              "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}})
    g.scene([g.add("nodes", {"mesh": g.quad(mat)}), g.camera(3.0, FILL_FOV)])
    path = g.write(tmp_path / ("quad.glb" if mode == "glb" else "quad.gltf"), mode)
    out = render(path)
    for (r, c), px in quadrant_centres(out).items():
        np.testing.assert_allclose(px, srgb_to_linear(TEXELS[r, c] / 255.0), rtol=1e-4, atol=1e-5)


def test_texture_coordinate_sets(tmp_path):
    """A material whose textures read TEXCOORD_1 (texCoord 1, or KHR_texture_transform's texCoord override) gives
    its primitives that set as their UVs: here the set mirrored left to right, so each quadrant shows the texel
    of the other column. Textures reading different sets take the lowest, with a warning."""
    def scene(name, emissive_info, base_info=None):
        g = Gltf()
        g.image_data_uri(png_bytes(TEXELS))
        g.add("samplers", {"magFilter": 9728, "minFilter": 9728})
        g.add("textures", {"source": 0, "sampler": 0})
        pbr = {"baseColorFactor": [0, 0, 0, 1]}
        if base_info:
            pbr["baseColorTexture"] = base_info
        mat = g.add("materials", {"emissiveFactor": [1, 1, 1], "emissiveTexture": emissive_info,
                                  "pbrMetallicRoughness": pbr})
        mesh = g.quad(mat)
        g.doc["meshes"][mesh]["primitives"][0]["attributes"]["TEXCOORD_1"] = g.accessor(
            [1, 1, 0, 1, 0, 0, 1, 0], "VEC2")
        g.scene([g.add("nodes", {"mesh": mesh}), g.camera(3.0, FILL_FOV)])
        return g.write(tmp_path / name)

    expect = {(r, c): srgb_to_linear(TEXELS[r, 1 - c] / 255.0) for r in (0, 1) for c in (0, 1)}
    for name, info in (("set1.gltf", {"index": 0, "texCoord": 1}),
                       ("override.gltf", {"index": 0, "extensions": {"KHR_texture_transform": {"texCoord": 1}}})):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            out = render(scene(name, info))
        for rc, px in quadrant_centres(out).items():
            np.testing.assert_allclose(px, expect[rc], rtol=1e-4, atol=1e-5)
    path = scene("mixed.gltf", {"index": 0, "texCoord": 1}, base_info={"index": 0})
    with pytest.warns(caustica.SceneWarning) as rec:
        out = render(path)
    assert [str(w.message) for w in rec] == [
        f"{path}: /materials/0: its textures read texture coordinate sets 0, 1; one set per material is "
        "supported: all read TEXCOORD_0"]
    for (r, c), px in quadrant_centres(out).items():
        np.testing.assert_allclose(px, srgb_to_linear(TEXELS[r, c] / 255.0), rtol=1e-4, atol=1e-5)


def test_base_color_texture_on_a_mirror_metal(tmp_path):
    """A smooth metal (metallic 1, roughness 0) reflects the default white environment
    (radiance 1) with reflectance F0 = base colour at normal incidence, so each quadrant
    shows its base-colour texel. Bilinear filtering on an 8x8 image made of 4x4 blocks of
    the 2x2 texels: the quadrant centres are far from the block edges."""
    g = Gltf()
    g.image_data_uri(png_bytes(np.repeat(np.repeat(TEXELS, 4, axis=0), 4, axis=1)))
    g.add("textures", {"source": 0})
    mat = g.add("materials", {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                                       "metallicFactor": 1.0, "roughnessFactor": 0.0}})
    g.scene([g.add("nodes", {"mesh": g.quad(mat)}), g.camera(3.0, FILL_FOV)])
    out = render(g.write(tmp_path / "metal.gltf"), size=64, spp=4)
    for (r, c), px in quadrant_centres(out).items():
        np.testing.assert_allclose(px, srgb_to_linear(TEXELS[r, c] / 255.0), rtol=0.03, atol=0.005)


def test_emissive_strength(tmp_path):
    g = Gltf()
    mat = g.add("materials", {"emissiveFactor": [1, 1, 1],
                              "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}},
                              "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}})
    g.doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
    g.scene([g.add("nodes", {"mesh": g.quad(mat, half=2.0)}), g.camera(3.0, FILL_FOV)])
    out = render(g.write(tmp_path / "emit.gltf"), size=16, spp=2)
    np.testing.assert_allclose(out, 5.0, rtol=1e-5)


def test_point_light_irradiance_on_diffuse_plane(tmp_path):
    """A point light of I candela at height 1 above a diffuse plane (metallic 0 with
    KHR_materials_ior = 1: no specular coat, so the BRDF is albedo / pi): the radiance is
    (I / 683) cos(theta) / d^2 * albedo / pi, cos / d^2 = (1 + r^2)^(-3/2)."""
    g = Gltf()
    albedo = 0.6
    mat = g.add("materials", {"pbrMetallicRoughness": {"baseColorFactor": [albedo] * 3 + [1],
                                                       "metallicFactor": 0.0, "roughnessFactor": 1.0},
                              "extensions": {"KHR_materials_ior": {"ior": 1.0}}})
    g.doc["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_ior"]
    intensity = 683.0 * 4.0
    g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": intensity}]}}
    light = g.add("nodes", {"translation": [0, 0, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}})
    fov = 0.2  # the view covers r < 3 tan(0.1) ~ 0.3
    g.scene([g.add("nodes", {"mesh": g.quad(mat, half=10.0)}), light, g.camera(3.0, fov)])
    n = 32
    out = render(g.write(tmp_path / "point.gltf"), size=n, spp=16)
    # Expected per pixel (at the pixel centre; the curvature within a pixel is negligible).
    t = 3.0 * math.tan(fov / 2)
    xs = ((np.arange(n) + 0.5) / n * 2 - 1) * t
    r2 = xs[None, :] ** 2 + xs[:, None] ** 2
    expected = intensity / 683.0 * albedo / math.pi * (1 + r2) ** -1.5
    np.testing.assert_allclose(out[..., 1], expected, rtol=0.01)
    np.testing.assert_allclose(out.mean(), expected.mean(), rtol=0.002)


def test_spot_and_directional_lights_render(tmp_path):
    """A directional light straight down on a diffuse plane: radiance E albedo / pi."""
    g = Gltf()
    mat = g.add("materials", {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1],
                                                       "metallicFactor": 0.0},
                              "extensions": {"KHR_materials_ior": {"ior": 1.0}}})
    g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 683.0 * 2}]}}
    # The light travels along the node's -z: the identity points it straight down onto the plane.
    light = g.add("nodes", {"extensions": {"KHR_lights_punctual": {"light": 0}}})
    g.scene([g.add("nodes", {"mesh": g.quad(mat, half=10.0)}), light, g.camera(3.0, 0.3)])
    out = render(g.write(tmp_path / "sun.gltf"), size=16, spp=2)
    np.testing.assert_allclose(out, 2.0 * 0.5 / math.pi, rtol=1e-3)


def test_transmission_glass_slab_with_volume_absorption(tmp_path):
    """A closed glass slab (two facing quads, 0.5 thick; KHR_materials_transmission 1,
    ior 1.5, KHR_materials_volume attenuationColor c at distance 1) seen head-on against the
    white default environment. With F = 0.04 at each face and a = c^0.5 the Beer-Lambert
    transmittance of one crossing, the paths that cross the slab k + 1 times sum to
    F + (1 - F)^2 a / (1 - F a) (1 for a = 1: a clear slab in a uniform light conserves it)."""
    g = Gltf()
    color = np.array([0.5, 0.8, 1.0])
    mat = g.add("materials", {"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
                              "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                             "KHR_materials_ior": {"ior": 1.5},
                                             "KHR_materials_volume": {"thicknessFactor": 0.5,
                                                                      "attenuationColor": list(color),
                                                                      "attenuationDistance": 1.0}}})
    g.doc["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"]
    front = g.add("nodes", {"mesh": g.quad(mat, half=3.0)})
    back = g.add("nodes", {"mesh": g.quad(mat, half=3.0, z=-0.5, facing_down=True)})
    g.scene([front, back, g.camera(3.0, 0.2)])
    out = render(g.write(tmp_path / "glass.gltf"), size=16, spp=64)
    assert np.all(np.isfinite(out))
    a = color ** 0.5
    expected = 0.04 + 0.96 ** 2 * a / (1 - 0.04 * a)
    np.testing.assert_allclose(out.reshape(-1, 3).mean(axis=0), expected, rtol=0.01)


def test_node_hierarchy_and_instancing_render(tmp_path):
    """One emissive mesh instanced twice (a translated child and a scaled node): both
    instances are visible in the render where the transforms put them."""
    g = Gltf()
    mat = g.add("materials", {"emissiveFactor": [1, 1, 1]})
    mesh = g.quad(mat, half=0.25)
    child = g.add("nodes", {"mesh": mesh, "translation": [0.5, 0, 0]})
    parent = g.add("nodes", {"children": [child], "translation": [0, 0.5, 0]})
    other = g.add("nodes", {"mesh": mesh, "translation": [-0.5, -0.5, 0], "scale": [0.5, 0.5, 0.5]})
    g.scene([parent, other, g.camera(3.0, FILL_FOV)])
    out = render(g.write(tmp_path / "inst.gltf"), size=32, spp=2)[..., 0]
    # Image rows go down, y up: the child quad covers x, y in [0.25, 0.75] -> rows 4..12, cols 20..28.
    assert np.allclose(out[5:11, 21:27], 1.0)
    # The scaled instance covers x, y in [-0.625, -0.375] -> rows 22..26, cols 5..10.
    assert np.allclose(out[23:25, 6:9], 1.0)
    assert out[16, 16] == 0.0 and out[8, 8] == 0.0


def test_gpu_instancing_places_each_instance(tmp_path):
    """EXT_mesh_gpu_instancing: a node's mesh once per instance, at the node's matrix times the instance's T R S
    (here a parent translation, then per instance a translation, a rotation about z, a scale): the same scene as
    one node per instance with those TRS, image for image; a rotation in normalized shorts reads the same."""
    t = [[0.5, 0.5, 0], [-0.5, 0.2, 0], [0.1, -0.6, 0]]
    angles = [0.0, 0.6, -1.1]
    q = [[0, 0, math.sin(a / 2), math.cos(a / 2)] for a in angles]
    s = [[1, 1, 1], [0.5, 0.8, 1], [1.2, 0.6, 1]]

    def scene(instanced, shorts=False):
        g = Gltf()
        mat = g.add("materials", {"emissiveFactor": [1, 0.5, 0.25]})
        mesh = g.quad(mat, half=0.2)
        if instanced:
            rot = (g.accessor([round(x * 32767) for v in q for x in v], "VEC4", "h", 5122) if shorts else
                   g.accessor([x for v in q for x in v], "VEC4"))
            if shorts:
                g.doc["accessors"][rot]["normalized"] = True
            attrs = {"TRANSLATION": g.accessor([x for v in t for x in v], "VEC3"), "ROTATION": rot,
                     "SCALE": g.accessor([x for v in s for x in v], "VEC3")}
            node = g.add("nodes", {"mesh": mesh, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attrs}}})
            g.doc["extensionsUsed"] = ["EXT_mesh_gpu_instancing"]
            g.doc["extensionsRequired"] = ["EXT_mesh_gpu_instancing"]
            kids = [node]
        else:
            kids = [g.add("nodes", {"mesh": mesh, "translation": t[i], "rotation": q[i], "scale": s[i]})
                    for i in range(3)]
        parent = g.add("nodes", {"children": kids, "translation": [0.1, 0, 0]})
        g.scene([parent, g.camera(3.0, FILL_FOV)])
        return g.write(tmp_path / f"i{int(instanced)}{int(shorts)}.gltf")

    a, b = caustica.load_scene(scene(True)), caustica.load_scene(scene(False))
    assert a.describe()["shapes"] == b.describe()["shapes"] == 3
    assert a.describe()["meshes"] == 1  # shared, not copied
    ia, ib = render(scene(True), spp=2), render(scene(False), spp=2)
    assert ia.mean() > 0.01
    np.testing.assert_allclose(ia, ib, atol=1e-6)
    ic = render(scene(True, shorts=True), spp=2)
    assert np.abs(ic - ib).mean() < 0.01 * ib.mean()  # shorts quantize the rotation: a few edge pixels move


SG = "KHR_materials_pbrSpecularGlossiness"


@pytest.mark.parametrize("sg", [
    {"diffuseFactor": [0.8, 0.2, 0.1, 1], "specularFactor": [0.04, 0.04, 0.04], "glossinessFactor": 0.7},  # plastic
    {"diffuseFactor": [0, 0, 0, 1], "specularFactor": [1.0, 0.766, 0.336], "glossinessFactor": 0.4},  # gold
    {"diffuseFactor": [0.5, 0.3, 0.2, 1], "specularFactor": [0.2, 0.25, 0.3], "glossinessFactor": 0.9},  # between
])
def test_specular_glossiness_is_metallic_roughness_with_specular(tmp_path, sg):
    """KHR_materials_pbrSpecularGlossiness renders as the dielectric metallic-roughness material with
    KHR_materials_specular it stands for: base colour the diffuse colour, metallic 0, roughness 1 - glossiness,
    specular colour the specular factor over F0(1.5) = 0.04 (the same image up to float rounding of that
    quotient), without a warning."""
    mr = {"pbrMetallicRoughness": {"baseColorFactor": sg["diffuseFactor"], "metallicFactor": 0,
                                   "roughnessFactor": 1 - sg["glossinessFactor"]},
          "extensions": {"KHR_materials_specular": {"specularColorFactor": [s / 0.04 for s in sg["specularFactor"]]}}}
    imgs = []
    for k, mat in enumerate(({"extensions": {SG: sg}}, mr)):
        g = Gltf()
        quad = g.quad(g.add("materials", mat))
        light = g.quad(g.add("materials", {"emissiveFactor": [4, 4, 4]}), half=0.3, facing_down=True)
        g.scene([g.add("nodes", {"mesh": quad, "rotation": [-0.38268343, 0, 0, 0.92387953]}),
                 g.add("nodes", {"mesh": light, "translation": [0, 0.8, 1.5]}), g.camera(3.0, FILL_FOV)])
        g.doc["extensionsUsed"] = [SG] if k == 0 else ["KHR_materials_specular"]
        path = g.write(tmp_path / f"sg{k}.gltf")
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            imgs.append(render(path, spp=8))
        assert not w, [str(x.message) for x in w]
    assert imgs[1].mean() > 0.01
    np.testing.assert_allclose(imgs[0], imgs[1], rtol=1e-4, atol=1e-5)


def sg_mirror(tmp_path, sg, texel=None):
    """A glossiness-1 (mirror) specular-glossiness plate with a black diffuse colour, seen straight down
    through a 0.1 rad field of view, under a black emitter of radiance 1 above the camera: each pixel is the
    plate's reflectance at incidence within 0.05 rad of the normal (optionally a 2 x 2 specularGlossiness
    texture of one RGBA texel)."""
    g = Gltf()
    sg = dict({"diffuseFactor": [0, 0, 0, 1], "glossinessFactor": 1.0}, **sg)
    if texel is not None:
        g.image_data_uri(png_bytes(np.tile(np.array(texel, np.uint8), (2, 2, 1))))
        g.add("textures", {"source": 0})
        sg["specularGlossinessTexture"] = {"index": 0}
    plate = g.quad(g.add("materials", {"extensions": {SG: sg}}))
    lamp = g.quad(g.add("materials", {"emissiveFactor": [1, 1, 1], "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}}),
                  half=3.0, z=4.0, facing_down=True)  # black: it reflects nothing back
    g.scene([g.add("nodes", {"mesh": plate}), g.add("nodes", {"mesh": lamp}), g.camera(3.0, 0.1)])
    g.doc["extensionsUsed"] = [SG]
    return render(g.write(tmp_path / "mirror.gltf"), size=8, spp=4)


def test_specular_glossiness_specular_is_the_normal_reflectance(tmp_path):
    """The specular colour is the reflectance at normal incidence, per channel: from the factor, and from the
    factor times the specularGlossinessTexture's RGB (sRGB; its alpha, the glossiness, 1 here). Within 0.05 rad
    of the normal the exact Fresnel of IOR 1.5 rises by under 1e-6 of its range above F0; bound 1e-4."""
    spec = [0.5, 0.3, 0.2]
    img = sg_mirror(tmp_path, {"specularFactor": spec})
    np.testing.assert_allclose(img, np.broadcast_to(spec, img.shape), atol=1e-4)
    texel = [200, 128, 40, 255]
    img = sg_mirror(tmp_path, {"specularFactor": [1.0, 0.5, 1.0]}, texel)
    want = srgb_to_linear(np.array(texel[:3]) / 255.0) * [1.0, 0.5, 1.0]
    np.testing.assert_allclose(img, np.broadcast_to(want, img.shape), atol=1e-4)


def test_specular_glossiness_exports_and_renders_the_same(tmp_path):
    """A textured specular-glossiness material exports to schema-valid JSON (a metallic_roughness with
    `specular_color` and its texture) that renders the glTF's image exactly."""
    from test_clearcoat import export_round_trip
    g = Gltf()
    rgba = np.zeros((4, 4, 4), np.uint8)
    rgba[..., 0], rgba[..., 1], rgba[..., 2], rgba[..., 3] = 220, 120, 30, 255
    rgba[:, :2, 3] = 90  # glossier on the right
    g.image_data_uri(png_bytes(rgba))
    g.add("textures", {"source": 0})
    sg = {"diffuseFactor": [0.3, 0.4, 0.5, 1], "specularFactor": [0.5, 0.5, 0.5], "glossinessFactor": 0.8,
          "specularGlossinessTexture": {"index": 0}, "diffuseTexture": {"index": 0}}
    g.scene([g.add("nodes", {"mesh": g.quad(g.add("materials", {"extensions": {SG: sg}})),
                             "rotation": [-0.38268343, 0, 0, 0.92387953]}), g.camera(3.0, FILL_FOV)])  # lit by
    # the default white environment
    g.doc["extensionsUsed"] = [SG]
    m = export_round_trip(tmp_path, g.write(tmp_path / "sg.gltf"), SG)
    assert m["type"] == "metallic_roughness" and m.get("metallic", 0) == 0
    assert "texture" in m["specular_color"]


def test_specular_glossiness_with_specular_or_ior_is_an_error(tmp_path):
    """KHR_materials_specular and KHR_materials_ior must not be used with specular-glossiness (their
    specifications' exclusions): the conversion sets the specular colour itself."""
    for other in ("KHR_materials_specular", "KHR_materials_ior"):
        g = Gltf()
        mat = g.add("materials", {"extensions": {SG: {"glossinessFactor": 0.5}, other: {}}})
        g.scene([g.add("nodes", {"mesh": g.quad(mat)}), g.camera(3.0, FILL_FOV)])
        g.doc["extensionsUsed"] = [SG, other]
        p = g.write(tmp_path / "both.gltf")
        with pytest.raises(caustica.InputError) as e:
            caustica.load_scene(p)
        assert str(e.value) == (f"{p}: /materials/0/extensions/{other}: must not be used with {SG} (which sets the "
                                "specular colour itself)")


def unlit_scene(tmp_path, name, unlit, lamp_light=True, half=1.0):
    """A 2 x 2 textured panel (TEXELS, nearest, times a factor) of half-width `half` (1: filling the view)
    seen head-on, under a strong point light; with `unlit` KHR_materials_unlit, else the equivalent by hand:
    black, emitting factor x texture. A diffuse floor just below the panel, facing up, catches its light
    (in view below a smaller panel)."""
    g = Gltf()
    g.image_data_uri(png_bytes(TEXELS))
    g.add("samplers", {"magFilter": 9728, "minFilter": 9728})
    g.add("textures", {"source": 0, "sampler": 0})
    factor = [0.9, 0.7, 1.0, 1.0]
    if unlit:
        mat = {"pbrMetallicRoughness": {"baseColorFactor": factor, "baseColorTexture": {"index": 0}},
               "extensions": {"KHR_materials_unlit": {}}}
    else:
        mat = {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
               "extensions": {"KHR_materials_ior": {"ior": 1.0}},  # no specular layer: black
               "emissiveFactor": factor[:3], "emissiveTexture": {"index": 0}}
    floor = g.add("materials", {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}})
    g.doc["extensionsUsed"] = ["KHR_lights_punctual", "KHR_materials_unlit" if unlit else "KHR_materials_ior"]
    g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 683.0 * 50}]}}
    nodes = [g.add("nodes", {"mesh": g.quad(g.add("materials", mat), half=half)}), g.camera(3.0, FILL_FOV),
             g.add("nodes", {"mesh": g.quad(floor, half=3.0), "translation": [0, -half - 0.1, 1],
                             "rotation": [-0.70710678, 0, 0, 0.70710678]})]
    if lamp_light:
        nodes.append(g.add("nodes", {"translation": [0.3, 0.2, 1.5], "extensions": {"KHR_lights_punctual": {"light": 0}}}))
    g.scene(nodes)
    return g.write(tmp_path / f"{name}.gltf")


def test_unlit_shows_its_base_colour_whatever_the_light(tmp_path):
    """KHR_materials_unlit (no warning): under a strong point light or none, each quadrant of the panel shows
    factor x texel (sRGB decoded) exactly: it reflects nothing and emits its base colour."""
    factor = np.array([0.9, 0.7, 1.0])
    for lamp in (True, False):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            out = render(unlit_scene(tmp_path, f"unlit{lamp}", True, lamp))
        assert not [x for x in w if "unlit" in str(x.message)], [str(x.message) for x in w]
        for (r, c), px in quadrant_centres(out).items():
            np.testing.assert_allclose(px, factor * srgb_to_linear(TEXELS[r, c] / 255.0), rtol=1e-4, atol=1e-5)


def test_unlit_is_a_black_emitter(tmp_path):
    """An unlit panel renders, light it casts on the floor included, as the same panel made black and
    emissive by hand (the same image with the same seed, up to float rounding), and that light is there."""
    a = render(unlit_scene(tmp_path, "unlit", True, half=0.5), size=48, spp=16)
    b = render(unlit_scene(tmp_path, "byhand", False, half=0.5), size=48, spp=16)
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-6)
    dark = render(unlit_scene(tmp_path, "dark", True, lamp_light=False, half=0.5), size=48, spp=16)
    assert dark[-4:].mean() > 0.01  # the floor at the bottom, lit by the panel alone


def test_errors_are_input_errors(tmp_path):
    p = tmp_path / "bad.gltf"
    p.write_text('{\n  "asset": {"version": "2.0"},\n  "nodes": [}\n')
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(p)
    assert str(e.value) == (f"{p}:3: invalid JSON: syntax error while parsing value - unexpected '}}'; "
                            "expected '[', '{', or a literal")
    p = tmp_path / "nobuf.gltf"
    p.write_text(json.dumps({"asset": {"version": "2.0"}, "buffers": [{"uri": "gone.bin", "byteLength": 8}]}))
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(p)
    assert str(e.value) == f"{p}: /buffers/0/uri: buffer file '{tmp_path}/gone.bin' does not exist"
    g = Gltf()
    mesh = g.quad()
    g.doc["meshes"][mesh]["primitives"][0]["indices"] = 17
    g.scene([g.add("nodes", {"mesh": mesh})])
    p = g.write(tmp_path / "range.gltf")
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(p)
    assert str(e.value) == f"{p}: /meshes/0/primitives/0/indices: index 17 out of range (/accessors has 4 entries)"


def test_cli_exit_code_and_message(tmp_path):
    p = tmp_path / "req.gltf"
    p.write_text(json.dumps({"asset": {"version": "2.0"}, "extensionsRequired": ["KHR_texture_basisu"]}))
    r = subprocess.run([BIN, "render", str(p), "--spp", "1", "-o", str(tmp_path / "x.exr"), "--quiet"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert f"{p}: /extensionsRequired/0: extension 'KHR_texture_basisu' is required but not supported" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_bad_geometry_is_skipped_and_renders(tmp_path):
    """NaN positions, degenerate triangles and out-of-range indices are skipped; the rest renders."""
    g = Gltf()
    nan = float("nan")
    pos = g.accessor([-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0, nan, 0, 0], "VEC3")
    ind = g.accessor([0, 1, 2, 0, 2, 3, 0, 4, 1, 0, 1, 1, 0, 9, 2], "SCALAR", "H", 5123)
    mat = g.add("materials", {"emissiveFactor": [2, 2, 2]})
    mesh = g.add("meshes", {"primitives": [{"attributes": {"POSITION": pos}, "indices": ind, "material": mat}]})
    g.scene([g.add("nodes", {"mesh": mesh}), g.camera(3.0, FILL_FOV)])
    path = g.write(tmp_path / "badgeom.gltf")
    with pytest.warns(Warning) as rec:
        s = caustica.load_scene(path, width=8, height=8)
    messages = [str(w.message) for w in rec]
    for what in ("1 triangle(s) with vertex indices out of range skipped",
                 "1 triangle(s) with non-finite (NaN or infinite) vertex positions skipped",
                 "1 degenerate (zero-area) triangle(s) skipped"):
        assert f"{path}: {what}" in messages
    np.testing.assert_allclose(caustica.render(s, spp=1), 2.0)


def test_cli_camera_by_name(tmp_path):
    g = Gltf()
    red = g.add("materials", {"emissiveFactor": [1, 0, 0]})
    green = g.add("materials", {"emissiveFactor": [0, 1, 0]})
    a = g.add("nodes", {"mesh": g.quad(red)})
    b = g.add("nodes", {"mesh": g.quad(green, z=-10.0), "translation": [100, 0, 0]})
    c0 = g.camera(3.0, FILL_FOV, name="front")
    cam1 = g.add("cameras", {"type": "perspective", "name": "far", "perspective": {"yfov": FILL_FOV, "znear": 0.1}})
    c1 = g.add("nodes", {"camera": cam1, "translation": [100, 0, -7]})
    g.scene([a, b, c0, c1])
    path = g.write(tmp_path / "cams.gltf")
    outs = {}
    for name in (None, "far"):
        o = tmp_path / f"{name}.pfm"
        args = [BIN, "render", path, "--spp", "1", "--width", "8", "--height", "8", "-o", str(o), "--quiet"]
        if name:
            args += ["--camera", name]
        r = subprocess.run(args, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        outs[name] = caustica.read_image(o)
    np.testing.assert_allclose(outs[None][4, 4], [1, 0, 0])
    np.testing.assert_allclose(outs["far"][4, 4], [0, 1, 0])
    r = subprocess.run([BIN, "render", path, "--camera", "nope", "-o", str(tmp_path / "n.pfm"), "--quiet"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert "no camera named 'nope' (cameras: front, far)" in r.stderr


# ------------------------------------------------------ KHR_materials_variants ---

def variants_scene(tmp_path, name="variants.gltf", **mv):
    """An emissive quad filling the view: red by default; variant "Green" maps it to green and "Blue and
    white" to blue, while "Plain" maps only the second quad (behind the camera), so the first keeps red."""
    g = Gltf()
    red, green, blue, white = (g.add("materials", {"emissiveFactor": c})
                               for c in ([1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]))
    front = g.quad(red)
    g.doc["meshes"][front]["primitives"][0]["extensions"] = {"KHR_materials_variants": {"mappings": [
        {"material": green, "variants": [0]}, {"material": blue, "variants": [1]}]}}
    back = g.quad(red, z=5.0)
    g.doc["meshes"][back]["primitives"][0]["extensions"] = {"KHR_materials_variants": {"mappings": [
        {"material": white, "variants": [1, 2]}]}}
    g.scene([g.add("nodes", {"mesh": front}), g.add("nodes", {"mesh": back}), g.camera(3.0, FILL_FOV)])
    g.doc["extensionsUsed"] = ["KHR_materials_variants"]
    g.doc["extensions"] = {"KHR_materials_variants": {"variants": [{"name": "Green"}, {"name": "Blue and white"},
                                                                   {"name": "Plain"}]}}
    for k, v in mv.items():
        g.doc["extensions"]["KHR_materials_variants"][k] = v
    return g.write(tmp_path / name)


def test_variants_choose_each_primitives_material(tmp_path):
    """KHR_materials_variants: a variant gives each primitive that maps it that material; one that does not map
    it (or no variant) keeps the primitive's own, as the extension says. Emissive colours, seen directly: the
    pixels are exactly the chosen material's."""
    path = variants_scene(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the extension is supported: no "not supported" warning
        d = caustica.load_scene_desc(path)
    assert list(d.variants) == ["Green", "Blue and white", "Plain"] and d.variant == ""
    expect = {None: [1, 0, 0], "Green": [0, 1, 0], "Blue and white": [0, 0, 1], "Plain": [1, 0, 0]}
    for variant, rgb in expect.items():
        s = caustica.load_scene(path, width=8, height=8, variant=variant)
        assert s.variant == (variant or "")
        np.testing.assert_array_equal(caustica.render(s, spp=1), np.broadcast_to(np.float32(rgb), (8, 8, 3)))
    # The second quad (behind the camera) is white in "Blue and white" and "Plain": the JSON export of a variant
    # has its materials only and renders the same.
    out = tmp_path / "plain.json"
    caustica.export_scene(path, out, variant="Plain")
    exported = json.loads(out.read_text())
    emissions = [np.broadcast_to(s.get("emission", 0), 3).tolist() for s in exported["shapes"]]  # 1: grey 1
    assert emissions == [[1, 0, 0], [1, 1, 1]] and len(exported["materials"]) == 2
    np.testing.assert_array_equal(render(out, size=8, spp=1), render(path, size=8, spp=1))


def test_variant_errors(tmp_path):
    path = variants_scene(tmp_path)
    with pytest.raises(caustica.SceneError) as e:
        caustica.load_scene(path, variant="Red")
    assert str(e.value) == f"{path}: no material variant named 'Red' (variants: Green, Blue and white, Plain)"
    g = Gltf()
    g.scene([g.add("nodes", {"mesh": g.quad()}), g.camera(3.0, FILL_FOV)])
    plain = g.write(tmp_path / "plain.gltf")
    with pytest.raises(caustica.SceneError) as e:
        caustica.load_scene_desc(plain, variant="Green")
    assert str(e.value) == f"{plain}: no material variant named 'Green' (the file has no KHR_materials_variants)"
    for scene in ("cornell", str(tmp_path / "missing.json")):
        with pytest.raises(caustica.InputError) as e:
            caustica.load_scene(scene, variant="Green")
        assert str(e.value) == (f"{scene}: has no material variants (--variant 'Green'): they come from glTF files "
                                "(KHR_materials_variants)")
    with pytest.raises(caustica.InputError, match="variant applies to glTF files"):
        caustica.load_scene({"shapes": {}}, variant="Green")
    s = caustica.load_scene(path)
    with pytest.raises(caustica.InputError, match="this scene is already loaded"):
        caustica.load_scene(s, variant="Green")
    with pytest.raises(caustica.InputError, match="variant: expected a variant name"):
        caustica.load_scene(path, variant="")
    # The extension's structure: a variant mapped twice on a primitive, an index past the variants, a variant
    # without a name, the root without its variants.
    doc = json.loads(open(path).read())
    maps = doc["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"]
    mp = "/meshes/0/primitives/0/extensions/KHR_materials_variants/mappings"
    cases = [
        (lambda d: maps[1]["variants"].append(0), f"{mp}/1/variants/1: variant 0 has a material already (each "
                                                  "variant is mapped once per primitive)"),
        (lambda d: maps[1]["variants"].append(3), f"{mp}/1/variants/1: index 3 out of range "
                                                  "(/extensions/KHR_materials_variants/variants has 3 entries)"),
        (lambda d: maps[0].pop("material"), f"{mp}/0/material: missing (an index into /materials)"),
        (lambda d: d["extensions"]["KHR_materials_variants"]["variants"][2].pop("name"),
         "/extensions/KHR_materials_variants/variants/2/name: missing (the variant's name)"),
        (lambda d: d["extensions"]["KHR_materials_variants"].pop("variants"),
         "/extensions/KHR_materials_variants/variants: missing (an array of variants, each with a name)"),
    ]
    for i, (change, message) in enumerate(cases):
        bad = json.loads(json.dumps(doc))
        maps = bad["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"]
        change(bad)
        p = tmp_path / f"bad{i}.gltf"
        p.write_text(json.dumps(bad))
        with pytest.raises(caustica.SceneError) as e:
            caustica.load_scene_desc(p)
        assert str(e.value) == f"{p}: {message}"


def test_variant_names_repeating_warn_and_pick_the_first(tmp_path):
    path = variants_scene(tmp_path, variants=[{"name": "Green"}, {"name": "Green"}, {"name": "Plain"}])
    with pytest.warns(caustica.SceneWarning) as rec:
        s = caustica.load_scene(path, width=4, height=4, variant="Green")
    assert [str(w.message) for w in rec] == [
        f"{path}: /extensions/KHR_materials_variants/variants: the name 'Green' is given to more than one variant; "
        "the first of them is used by that name"]
    np.testing.assert_array_equal(caustica.render(s, spp=1)[0, 0], [0, 1, 0])


def test_cli_variant(tmp_path):
    path = variants_scene(tmp_path)
    o = tmp_path / "blue.pfm"
    r = subprocess.run([BIN, "render", path, "--variant", "Blue and white", "--spp", "1", "--width", "4",
                        "--height", "4", "-o", str(o), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(caustica.read_image(o)[2, 2], [0, 0, 1])
    r = subprocess.run([BIN, "info", path], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "variants:    Green, Blue and white, Plain (none chosen: --variant NAME)" in r.stdout
    r = subprocess.run([BIN, "info", path, "--variant", "Plain", "--json"], capture_output=True, text=True)
    info = json.loads(r.stdout)
    assert info["variants"] == ["Green", "Blue and white", "Plain"] and info["variant"] == "Plain"
    r = subprocess.run([BIN, "render", path, "--variant", "Red", "-o", str(tmp_path / "n.pfm"), "--quiet"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip() == (f"caustica: error: {path}: no material variant named 'Red' "
                                "(variants: Green, Blue and white, Plain)")
    out = tmp_path / "green.json"
    r = subprocess.run([BIN, "export", path, "--variant", "Green", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(render(out, size=4, spp=1)[1, 1], [0, 1, 0])
    # converge takes it too: a reference of the green variant.
    ref = tmp_path / "ref.pfm"
    r = subprocess.run([BIN, "converge", path, "--variant", "Green", "--make-reference", "--spp", "1", "--width", "4",
                        "--height", "4", "-o", str(ref), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(caustica.read_image(ref)[1, 1], [0, 1, 0])


def test_node_visibility_hides_meshes_and_lights_below_not_cameras(tmp_path):
    """KHR_node_visibility: a node with visible false hides its meshes and lights and those of every node below
    it (a child's own visible true included); its cameras stay. The red quad in front is hidden, so the camera
    (itself below the hidden node) sees the green one behind it."""
    g = Gltf()
    red = g.add("materials", {"emissiveFactor": [1, 0, 0]})
    green = g.add("materials", {"emissiveFactor": [0, 1, 0]})
    g.doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 5}]}}
    lamp = g.add("nodes", {"translation": [0, 0, 1], "extensions": {"KHR_lights_punctual": {"light": 0},
                                                                     "KHR_node_visibility": {"visible": True}}})
    cam = g.camera(3.0, FILL_FOV)
    front = g.add("nodes", {"mesh": g.quad(red), "children": [lamp, cam],
                            "extensions": {"KHR_node_visibility": {"visible": False}}})
    back = g.add("nodes", {"mesh": g.quad(green, z=-1.0, half=2.0)})
    g.scene([front, back])
    g.doc["extensionsUsed"] = ["KHR_lights_punctual", "KHR_node_visibility"]
    path = g.write(tmp_path / "hidden.gltf")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # supported: no warning
        d = caustica.describe(path)
    assert (d["shapes"], d["area_lights"], d["lights"]) == (1, 1, 0)  # the green quad; no point light
    np.testing.assert_array_equal(render(path, size=4, spp=1)[2, 2], [0, 1, 0])
    g.doc["nodes"][front]["extensions"]["KHR_node_visibility"]["visible"] = True
    path = g.write(tmp_path / "shown.gltf")
    d = caustica.describe(path)
    assert (d["shapes"], d["area_lights"], d["lights"]) == (2, 2, 1)
    np.testing.assert_array_equal(render(path, size=4, spp=1)[2, 2], [1, 0, 0])
    g.doc["nodes"][front]["extensions"]["KHR_node_visibility"]["visible"] = 0
    path = g.write(tmp_path / "bad.gltf")
    with pytest.raises(caustica.SceneError) as e:
        caustica.describe(path)
    assert str(e.value) == f"{path}: /nodes/{front}/extensions/KHR_node_visibility/visible: expected true or false, got number"
