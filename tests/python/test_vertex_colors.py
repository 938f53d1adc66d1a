"""Vertex colours (material flag kVertexColor, docs/materials.md): the main colour times the triangle's interpolated
vertex colour. A diffuse quad under a uniform sky of radiance 1 reflects its albedo, so each triangle's centroid
shows the mean of its three vertex colours (times the material's colour); the colours come from JSON meshes, glTF's
COLOR_0 (float, and normalized bytes with alpha), PLY (8- and 16-bit sRGB, float linear; vertex or face colours), OBJ (`v x y z r g b` and
#MRGB, sRGB) and Mitsuba's mesh_attribute texture, and survive export to JSON; a coloured OBJ or PLY file rendered
alone shows them. bench/compare_mitsuba_xml.py's scene `colored`
renders them against Mitsuba 3."""
import base64
import json
import struct
import warnings

import numpy as np
import pytest

import caustica

CUDA, WHY = caustica.cuda_status()

from conftest import mean_and_se, srgb_to_linear
from serialized_mesh import write_serialized

# A unit quad in z = 0 facing +z: triangles (0, 1, 2) and (0, 2, 3); corners red, green, blue, white.
QUAD_P = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
QUAD_I = [0, 1, 2, 0, 2, 3]
COLORS = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]
CAMERA = {"type": "orthographic", "position": [0, 0, 3], "target": [0, 0, 0], "view_size": 2, "width": 48,
          "height": 48}


def quad_scene(colors=COLORS, vertex_colors=True, reflectance=0.5):
    mesh = {"positions": QUAD_P, "indices": QUAD_I}
    if colors is not None:
        mesh["colors"] = colors
    return {"camera": CAMERA, "max_depth": 2,
            "materials": {"m": {"type": "diffuse", "reflectance": reflectance, "vertex_colors": vertex_colors}},
            "shapes": [dict(mesh, type="mesh", material="m")],
            "lights": [{"type": "environment", "radiance": 1}]}


def centroid_pixels(img):
    """Mean and standard error per channel of a 5 x 5 patch at the centroid of each triangle (image rows from the
    top: the camera looks down -z with +y up)."""
    out = []
    for tri in ((0, 1, 2), (0, 2, 3)):
        c = np.mean([QUAD_P[i] for i in tri], axis=0)
        col, row = int((c[0] + 1) / 2 * 48), int((1 - c[1]) / 2 * 48)
        patch = img[row - 2:row + 3, col - 2:col + 3]
        out.append([mean_and_se(patch[:, :, k]) for k in range(3)])
    return out


def expect_centroids(img, colors, reflectance, per_face=False):
    """colors: one per vertex (the centroid shows their mean), or with per_face one per triangle."""
    for f, (tri, stats) in enumerate(zip(((0, 1, 2), (0, 2, 3)), centroid_pixels(img))):
        want = reflectance * (np.asarray(colors[f]) if per_face else np.mean([colors[i] for i in tri], axis=0))
        for k, (m, se) in enumerate(stats):
            # 5 standard errors of the patch mean (its pixels' spread bounds the noise; the colour varies by
            # under 1% across the patch), plus 1e-3 for that variation.
            assert abs(m - want[k]) <= 5 * se + 1e-3 * max(want[k], 0.1), (tri, k, m, want[k], se)


def render(scene, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.asarray(caustica.render(scene, sampler="independent", **kw), np.float64)


def test_each_triangle_shows_its_interpolated_colour():
    img = render(quad_scene(), spp=64, seed=1)
    expect_centroids(img, COLORS, 0.5)


def test_without_the_flag_or_the_colours_the_material_keeps_its_colour():
    plain = render(quad_scene(colors=None, vertex_colors=False), spp=4, seed=2)
    np.testing.assert_array_equal(render(quad_scene(vertex_colors=False), spp=4, seed=2), plain)
    np.testing.assert_array_equal(render(quad_scene(colors=None), spp=4, seed=2), plain)  # white where none
    # A uniform vertex colour is the same as that colour in the material.
    c = [0.3, 0.6, 0.9]
    a = render(quad_scene(colors=[c] * 4), spp=4, seed=2)
    b = render(quad_scene(colors=None, vertex_colors=False, reflectance=[0.5 * x for x in c]), spp=4, seed=2)
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("integrator", ["sppm", "bdpt", "vcm", "light", "restir"])
def test_every_integrator_reads_them(integrator):
    """The photon and bidirectional integrators shade through the same surface_material: the centroids agree."""
    img = render(quad_scene(), integrator=integrator, spp=32, seed=3)
    expect_centroids(img, COLORS, 0.5)


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", ["path", "sppm", "vcm"])
def test_cuda_reads_them(integrator):
    """On the GPU the colours travel with the scene's arrays (DeviceScene): the same centroids."""
    img = render(quad_scene(), integrator=integrator, spp=32, seed=3, device="cuda")
    expect_centroids(img, COLORS, 0.5)


def test_json_errors():
    bad = quad_scene(colors=[[1, 0, 0]] * 3)
    with pytest.raises(caustica.InputError, match="/colors: expected one colour"):
        caustica.load_dict(bad)
    bad = quad_scene(colors=[[1, 0, 0]] * 3 + [[-1, 0, 0]])
    with pytest.raises(caustica.InputError, match=r"/colors/3: expected a colour with components >= 0"):
        caustica.load_dict(bad)
    bad = quad_scene(vertex_colors="yes")
    with pytest.raises(caustica.InputError, match="vertex_colors: expected true or false"):
        caustica.load_dict(bad)


def gltf_quad(path, color_accessor):
    """A glTF file of the quad, its COLOR_0 from (component type, normalized, type, bytes)."""
    pos = np.array(QUAD_P, np.float32).tobytes()
    idx = np.array(QUAD_I, np.uint16).tobytes()
    ctype, normalized, atype, cbytes = color_accessor
    blob = pos + idx + b"\0" * (-len(idx) % 4) + cbytes
    off_c = len(pos) + len(idx) + (-len(idx) % 4)
    g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 2}, "indices": 1, "material": 0}]}],
         "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0,
                                                 "roughnessFactor": 1}}],
         "buffers": [{"byteLength": len(blob),
                      "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
         "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                         {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)},
                         {"buffer": 0, "byteOffset": off_c, "byteLength": len(cbytes)}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                        "min": [-1, -1, 0], "max": [1, 1, 0]},
                       {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
                       {"bufferView": 2, "componentType": ctype, "normalized": normalized, "count": 4,
                        "type": atype}]}
    path.write_text(json.dumps(g))


@pytest.mark.parametrize("form", ["float", "bytes"])
def test_gltf_color_0_multiplies_the_base_colour(tmp_path, form):
    if form == "float":
        acc = (5126, False, "VEC3", np.array(COLORS, np.float32).tobytes())
        want = COLORS
    else:  # normalized unsigned bytes with alpha: linear values k / 255, the alpha not applied
        b = np.array([[255, 0, 0, 255], [0, 255, 0, 128], [0, 0, 128, 255], [255, 255, 255, 255]], np.uint8)
        acc = (5121, True, "VEC4", b.tobytes())
        want = (b[:, :3] / 255.0).tolist()
    f = tmp_path / "q.gltf"
    gltf_quad(f, acc)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        s = caustica.load_scene(str(f))
    if form == "bytes":
        assert any("alpha of vertex colours (COLOR_0) is not applied" in str(x.message) for x in w)
    out = tmp_path / "q.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the default camera and light, the alpha again
        caustica.export_scene(str(f), str(out))
    d = json.loads(out.read_text())
    mesh = next(iter(d["meshes"].values()))
    np.testing.assert_allclose(mesh["colors"], want, rtol=1e-6, atol=1e-7)
    mat = next(m for name, m in d["materials"].items() if name.endswith("+COLOR_0"))
    assert mat["vertex_colors"] is True
    # Rendered as the JSON quad with those colours and a metallic-roughness base of 0.5 (glTF's default material
    # is not used): the same image from the exported file.
    np.testing.assert_array_equal(render(s, spp=2, seed=1), render(caustica.load_scene(str(out)), spp=2, seed=1))


def write_ply_colored(path, colors, kind):
    t = {"uchar": "uchar", "ushort": "ushort", "float": "float"}[kind]
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                f"property {t} red\nproperty {t} green\nproperty {t} blue\nelement face 2\n"
                "property list uchar int vertex_indices\nend_header\n")
        for p, c in zip(QUAD_P, colors):
            f.write(" ".join(str(v) for v in list(p) + list(c)) + "\n")
        f.write("3 0 1 2\n3 0 2 3\n")


@pytest.mark.parametrize("kind", ["uchar", "ushort", "float"])
def test_ply_colours(tmp_path, kind):
    """8- and 16-bit PLY colours are sRGB (decoded), float ones linear; a JSON mesh file's colours are used by a
    material with vertex_colors."""
    top = {"uchar": 255, "ushort": 65535, "float": 1.0}[kind]
    raw = [[top, 0, 0], [0, top // 2 if kind != "float" else 0.5, 0], [0, 0, top], [top, top, top]]
    write_ply_colored(tmp_path / "q.ply", raw, kind)
    want = np.array(raw, np.float64) / top
    if kind != "float":
        want = srgb_to_linear(want)
    scene = quad_scene()
    scene["shapes"] = [{"type": "mesh", "file": str(tmp_path / "q.ply"), "material": "m"}]
    img = render(scene, spp=64, seed=4)
    expect_centroids(img, want.tolist(), 0.5)


def mitsuba_quad(folder, kind):
    """A Mitsuba XML scene in `folder` of the mesh file q.<kind> under a diffuse BSDF whose reflectance is the
    mesh_attribute texture of vertex_color with scale 0.5, seen as quad_scene sees the quad; returns its path."""
    f = folder / "m.xml"
    f.write_text(f"""<scene version="3.0.0"><integrator type="path"><integer name="max_depth" value="2"/>
      </integrator><sensor type="orthographic"><transform name="to_world"><lookat origin="0, 0, 3"
      target="0, 0, 0" up="0, 1, 0"/></transform><film type="hdrfilm"><integer name="width" value="48"/>
      <integer name="height" value="48"/><rfilter type="box"/></film></sensor>
      <shape type="{kind}"><string name="filename" value="q.{kind}"/><bsdf type="diffuse">
      <texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/>
      <float name="scale" value="0.5"/></texture></bsdf></shape><emitter type="constant"/></scene>""")
    return str(f)


def test_mitsuba_mesh_attribute_reads_ply_colours(tmp_path):
    """Mitsuba's mesh_attribute texture of vertex_color (times its scale) on a diffuse BSDF over a PLY with float
    colours: the same centroids as the JSON quad."""
    write_ply_colored(tmp_path / "q.ply", COLORS, "float")
    img = render(caustica.load_scene(mitsuba_quad(tmp_path, "ply")), spp=64, seed=5)
    expect_centroids(img, COLORS, 0.5)


@pytest.mark.parametrize("body,message", [
    ('<shape type="rectangle"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">'
     '<string name="name" value="vertex_color"/></texture></bsdf></shape>',
     "the BSDF reads the mesh attribute 'vertex_color', which this shape does not have"),
    # Mitsuba 3.9.1 makes no attribute of a serialized file's colours (it renders this black): an error here.
    ('<shape type="serialized"><string name="filename" value="c.serialized"/><bsdf type="diffuse">'
     '<texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture>'
     '</bsdf></shape>',
     "the BSDF reads the mesh attribute 'vertex_color', which this shape does not have"),
    ('<shape type="rectangle"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">'
     '<string name="name" value="uv"/></texture></bsdf></shape>',
     "unsupported mesh attribute 'uv' (supported: vertex_color, face_color)"),
    # A serialized mesh's colours are per vertex (and read past); PLY face colours are Mitsuba's face_color.
    ('<shape type="serialized"><string name="filename" value="c.serialized"/><bsdf type="diffuse">'
     '<texture type="mesh_attribute" name="reflectance"><string name="name" value="face_color"/></texture>'
     '</bsdf></shape>',
     "the BSDF reads the mesh attribute 'face_color', which this shape does not have"),
    ('<shape type="ply"><string name="filename" value="f.ply"/><bsdf type="diffuse">'
     '<texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture>'
     '</bsdf></shape>',
     "the BSDF reads the mesh attribute 'vertex_color', which this shape does not have"),
    ('<shape type="rectangle"><bsdf type="roughconductor"><texture type="mesh_attribute" name="alpha">'
     '<string name="name" value="vertex_color"/></texture></bsdf></shape>',
     "a mesh_attribute texture is supported as a BSDF's colour only"),
    ('<shape type="rectangle"><emitter type="area"><texture type="mesh_attribute" name="radiance">'
     '<string name="name" value="vertex_color"/></texture></emitter></shape>',
     "not as radiance"),
])
def test_mitsuba_mesh_attribute_errors(tmp_path, body, message):
    write_serialized(tmp_path / "c.serialized", [dict(positions=QUAD_P, indices=np.reshape(QUAD_I, (-1, 3)),
                                                     colours=COLORS)])
    write_ply_face_colored(tmp_path / "f.ply", COLORS[:2])
    f = tmp_path / "e.xml"
    f.write_text(f'<scene version="3.0.0">{body}</scene>')
    with pytest.raises(caustica.InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        caustica.load_scene(str(f))


def write_ply_face_colored(path, colors, kind="float"):
    """The quad as PLY with a colour per triangle (face element properties red green blue)."""
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 2\nproperty list uchar int vertex_indices\n"
                f"property {kind} red\nproperty {kind} green\nproperty {kind} blue\nend_header\n")
        for p in QUAD_P:
            f.write(" ".join(str(v) for v in p) + "\n")
        for t, c in zip(np.reshape(QUAD_I, (-1, 3)), colors):
            f.write("3 " + " ".join(str(v) for v in t) + " " + " ".join(str(v) for v in c) + "\n")


@pytest.mark.parametrize("kind", ["uchar", "float"])
def test_ply_face_colours(tmp_path, kind):
    """PLY face colours colour each face (8-bit sRGB decoded, float linear): through a JSON material with
    vertex_colors and through Mitsuba's mesh_attribute of face_color, each triangle's centroid shows its face's
    colour (the colour is constant over the face, so the patch shows it exactly)."""
    raw = [[255, 0, 64], [0, 128, 255]] if kind == "uchar" else [[1, 0, 0.25], [0, 0.5, 1]]
    write_ply_face_colored(tmp_path / "q.ply", raw, kind)
    want = np.array(raw, np.float64)
    if kind == "uchar":
        want = srgb_to_linear(want / 255)
    scene = quad_scene()
    scene["shapes"] = [{"type": "mesh", "file": str(tmp_path / "q.ply"), "material": "m"}]
    expect_centroids(render(scene, spp=64, seed=9), want, 0.5, per_face=True)
    xml = mitsuba_quad(tmp_path, "ply")
    with open(xml) as f:
        text = f.read().replace('value="vertex_color"', 'value="face_color"')
    with open(xml, "w") as f:
        f.write(text)
    expect_centroids(render(caustica.load_scene(xml), spp=64, seed=10), want, 0.5, per_face=True)


def write_obj_colored(path, srgb, mrgb=False):
    """The quad as OBJ with sRGB vertex colours: `v x y z r g b`, or ZBrush's #MRGB line after the vertices."""
    if mrgb:
        hexes = "".join("ff%02x%02x%02x" % tuple(int(round(255 * x)) for x in c) for c in srgb)
        text = "".join("v %g %g %g\n" % tuple(p) for p in QUAD_P) + f"#MRGB {hexes}\n"
    else:
        text = "".join("v %g %g %g %g %g %g\n" % (*p, *c) for p, c in zip(QUAD_P, srgb))
    path.write_text(text + "f 1 2 3\nf 1 3 4\n")


@pytest.mark.parametrize("mrgb", [False, True])
def test_obj_colours_are_srgb(tmp_path, mrgb):
    """OBJ vertex colours are sRGB (Blender writes and reads them so), decoded to linear: through a JSON mesh file
    and a material with vertex_colors, and through Mitsuba's mesh_attribute on an obj shape, the centroids show
    the decoded colours."""
    raw = [[1, 0, 0], [0, 128 / 255, 0], [0, 0, 64 / 255], [1, 1, 1]]
    write_obj_colored(tmp_path / "q.obj", raw, mrgb)
    want = srgb_to_linear(np.array(raw, np.float64)).tolist()
    scene = quad_scene()
    scene["shapes"] = [{"type": "mesh", "file": str(tmp_path / "q.obj"), "material": "m"}]
    expect_centroids(render(scene, spp=64, seed=6), want, 0.5)
    expect_centroids(render(caustica.load_scene(mitsuba_quad(tmp_path, "obj")), spp=64, seed=7), want, 0.5)


@pytest.mark.parametrize("ext", ["obj", "ply"])
def test_a_mesh_file_alone_shows_its_colours(tmp_path, ext):
    """A coloured OBJ or PLY file rendered alone (default camera and sky): its default material is diffuse 1 times
    the vertex colours, so a uniform colour c renders as the uncoloured file with a diffuse material of c (MTL Kd
    for the OBJ, a JSON copy of the scene for the PLY), sample for sample."""
    c = [0.8, 0.4, 0.2]  # sRGB in the OBJ file; 8-bit sRGB in the PLY file
    if ext == "obj":
        write_obj_colored(tmp_path / "q.obj", [c] * 4)
        lin = srgb_to_linear(np.array(c)).tolist()
        (tmp_path / "k.mtl").write_text("newmtl k\nKd %r %r %r\n" % tuple(lin))
        (tmp_path / "k.obj").write_text("mtllib k.mtl\nusemtl k\n" + "".join("v %g %g %g\n" % tuple(p) for p in QUAD_P)
                                        + "f 1 2 3\nf 1 3 4\n")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the default camera and light
            colored, plain = caustica.load_scene(str(tmp_path / "q.obj")), caustica.load_scene(str(tmp_path / "k.obj"))
    else:
        b = [int(round(255 * x)) for x in c]
        write_ply_colored(tmp_path / "q.ply", [b] * 4, "uchar")
        lin = srgb_to_linear(np.array(b) / 255.0).tolist()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the default camera and light
            caustica.export_scene(str(tmp_path / "q.ply"), str(tmp_path / "q.json"))
        d = json.loads((tmp_path / "q.json").read_text())
        (name, mat), = d["materials"].items()
        assert mat["vertex_colors"] is True and mat["reflectance"] == 1, mat
        d["materials"][name] = {"type": "diffuse", "reflectance": lin}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            colored, plain = caustica.load_scene(str(tmp_path / "q.ply")), caustica.load_dict(d)
    a, b = render(colored, spp=4, seed=8), render(plain, spp=4, seed=8)
    assert a.mean() > 0.05
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)
