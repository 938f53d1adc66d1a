"""Mitsuba 3 XML: serialized meshes, shapegroups and instances, cylinders, the checkerboard texture, and the
direct and ptracer integrators (docs/formats-mitsuba.md). Each is checked against something it must equal:
the same mesh as a PLY file, the same shapes placed without instancing, the cylinder's projected area and the
checkerboard's quadrants (analytic, Mitsuba's definitions), path with max depth 2, and the light tracer.
bench/compare_mitsuba_xml.py renders the scenes `instanced`, `direct` and `ptracer` against Mitsuba 3 itself."""
import struct
import subprocess
import warnings
import zlib

import numpy as np
import pytest

import caustica

from conftest import mean_and_se
from serialized_mesh import mesh_bytes, write_serialized

SENSOR = """<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 2, 6" target="0, 0.5, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
    <rfilter type="box"/></film></sensor>"""
LIGHT = """<shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="90"/>
    <translate y="3"/></transform><emitter type="area"><rgb name="radiance" value="12, 11, 9"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.2, 0.25"/></emitter>"""


def load(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return caustica.load_scene(str(path), **kw)


def render(scene, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.asarray(caustica.render(scene, **kw), np.float64)


def scene_xml(tmp_path, body, name="s.xml", integrator='<integrator type="path"/>'):
    f = tmp_path / name
    f.write_text(f'<scene version="3.0.0">\n{integrator}\n{SENSOR}\n{LIGHT}\n{body}\n</scene>\n')
    return f


def regions_agree(a, b, k=4.0, size=8):
    """Per size x size region and channel, the means agree within k standard errors of their difference (each
    region's pixel spread bounds its noise from above); returns the regions that do not."""
    bad = []
    for i in range(0, a.shape[0], size):
        for j in range(0, a.shape[1], size):
            for c in range(3):
                ma, sa = mean_and_se(a[i:i + size, j:j + size, c])
                mb, sb = mean_and_se(b[i:i + size, j:j + size, c])
                if abs(ma - mb) > k * np.hypot(sa, sb) + 1e-6:
                    bad.append((i, j, c, ma, mb))
    return bad


# A bumpy sheet with normals and UVs (Mitsuba's v, pointing down), and a second mesh.
def sheet(n=6):
    x, z = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n))
    y = 0.15 * np.sin(3 * x) * np.cos(2 * z) + 0.3
    p = np.stack([x, y, z], -1).reshape(-1, 3)
    nrm = np.stack([-0.45 * np.cos(3 * x) * np.cos(2 * z), np.ones_like(x), 0.3 * np.sin(3 * x) * np.sin(2 * z)],
                   -1).reshape(-1, 3)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    uv = np.stack([(x + 1) / 2, (z + 1) / 2], -1).reshape(-1, 2)
    idx = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            idx += [(a, d, b), (b, d, e)]
    return dict(positions=p.astype(np.float32), indices=np.array(idx), normals=nrm.astype(np.float32),
                uvs=uv.astype(np.float32))


def write_ply(path, m, normals=True):
    p, idx = m["positions"], m["indices"]
    props = "property float x\nproperty float y\nproperty float z\n"
    if normals:
        props += "property float nx\nproperty float ny\nproperty float nz\n"
    props += "property float u\nproperty float v\n"
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(p)}\n{props}element face {len(idx)}\n"
                "property list uchar int vertex_indices\nend_header\n")
        for i in range(len(p)):
            vals = list(p[i]) + (list(m["normals"][i]) if normals else []) + list(m["uvs"][i])
            f.write(" ".join(repr(float(v)) for v in vals) + "\n")
        for t in idx:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")


TEXTURED = """<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="tex.exr"/>
  <string name="filter_type" value="nearest"/></texture></bsdf>"""


def texture(tmp_path):
    t = np.zeros((4, 4, 3), np.float32)
    t[:] = (0.1, 0.2, 0.6)
    t[:2, :] = (0.8, 0.3, 0.1)  # the top half of the image differs from the bottom: v's direction shows
    t[:, :1] = (0.9, 0.9, 0.9)  # and the left column from the rest: u's
    caustica.write_image(str(tmp_path / "tex.exr"), t)


@pytest.mark.parametrize("version,double,normals", [(4, False, True), (3, True, True), (4, False, False)])
def test_serialized_renders_as_the_same_ply(tmp_path, version, double, normals):
    """The same mesh (positions, normals or none, UVs) as a serialized file and as a PLY renders the same image,
    seed for seed: both get Mitsuba's v flipped to caustica's, and without normals the same smooth ones."""
    texture(tmp_path)
    m = sheet()
    other = dict(positions=[(0, 0, 0), (1, 0, 0), (0, 1, 0)], indices=[(0, 1, 2)])
    sm = dict(m, colours=np.ones((len(m["positions"]), 3)), name="sheet")  # vertex colours are read past
    if not normals:
        del sm["normals"]
    write_serialized(tmp_path / "m.serialized", [other, sm], version=version, double=double)
    write_ply(tmp_path / "m.ply", m, normals=normals)
    a = scene_xml(tmp_path, f"""<shape type="serialized"><string name="filename" value="m.serialized"/>
      <integer name="shape_index" value="1"/>{TEXTURED}</shape>""", "a.xml")
    b = scene_xml(tmp_path, f"""<shape type="ply"><string name="filename" value="m.ply"/>{TEXTURED}</shape>""",
                  "b.xml")
    sa, sb = load(a), load(b)
    assert sa.describe()["triangles"] == sb.describe()["triangles"] == len(m["indices"]) + 2  # + the light's two
    ia, ib = render(sa, spp=4, seed=7), render(sb, spp=4, seed=7)
    assert ia.mean() > 0.05
    np.testing.assert_array_equal(ia, ib)


def test_serialized_shape_index_and_face_normals(tmp_path):
    m = sheet()
    write_serialized(tmp_path / "m.serialized", [dict(positions=[(0, 0, 0), (1, 0, 0), (0, 1, 0)],
                                                      indices=[(0, 1, 2)]), m])
    for index, tris in ((0, 1 + 2), (1, len(m["indices"]) + 2)):  # + the light's two
        f = scene_xml(tmp_path, f"""<shape type="serialized"><string name="filename" value="m.serialized"/>
          <integer name="shape_index" value="{index}"/></shape>""")
        assert load(f).describe()["triangles"] == tris
    # face_normals drops the file's normals: flat shading changes the image of the smooth sheet.
    imgs = []
    for fn in ("false", "true"):
        f = scene_xml(tmp_path, f"""<shape type="serialized"><string name="filename" value="m.serialized"/>
          <integer name="shape_index" value="1"/><boolean name="face_normals" value="{fn}"/></shape>""")
        imgs.append(render(load(f), spp=4, seed=1))
    assert not np.array_equal(imgs[0], imgs[1])


def serialized_error(tmp_path, data, index=0):
    (tmp_path / "bad.serialized").write_bytes(data)
    f = scene_xml(tmp_path, f"""<shape type="serialized"><string name="filename" value="bad.serialized"/>
      <integer name="shape_index" value="{index}"/></shape>""")
    with pytest.raises(caustica.InputError) as e:
        load(f)
    msg = str(e.value)
    assert msg.startswith(f"{f}:") and "bad.serialized: " in msg, msg
    return msg


def test_serialized_errors_name_the_file_and_the_problem(tmp_path):
    tri = dict(positions=[(0, 0, 0), (1, 0, 0), (0, 1, 0)], indices=[(0, 1, 2)])
    good = mesh_bytes(**tri)
    table = (0).to_bytes(8, "little") + (1).to_bytes(4, "little")
    assert "not a Mitsuba serialized mesh file" in serialized_error(tmp_path, b"PK\x03\x04" + good + table)
    assert "unsupported serialized format version 5" in serialized_error(
        tmp_path, good[:2] + (5).to_bytes(2, "little") + good[4:] + table)
    assert "shape_index 1 is out of range (the file holds 1 mesh)" in serialized_error(tmp_path, good + table, 1)
    assert "corrupt compressed data" in serialized_error(tmp_path, good[:6] + b"\xff" * 20 + good[26:] + table)
    assert "ends early" in serialized_error(tmp_path, good[:len(good) - 8] + table)
    assert "vertex index 7 out of range (3 vertices)" in serialized_error(
        tmp_path, mesh_bytes(positions=tri["positions"], indices=[(0, 1, 7)]) + table)
    assert "1000 vertices and 1 triangles do not fit" in serialized_error(tmp_path, raw_mesh(0x1000, 1000, tri) + table)
    assert "neither single nor double precision" in serialized_error(tmp_path, raw_mesh(0, 3, tri) + table)
    assert "does not fit the file" in serialized_error(tmp_path, good + (0).to_bytes(8, "little") +
                                                       (9).to_bytes(4, "little"))


def raw_mesh(flags, nv, tri):
    """A mesh record with the given flags and claimed vertex count over a triangle's data (one triangle)."""
    body = struct.pack("<I", flags) + b"m\0" + struct.pack("<QQ", nv, 1)
    body += np.asarray(tri["positions"], np.float32).tobytes() + np.asarray(tri["indices"], np.uint32).tobytes()
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(body)


GROUP_SHAPES = [
    ('<shape type="sphere"><float name="radius" value="0.3"/>{tw}'
     '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.6, 0.15, 0.1"/></bsdf></shape>',
     '<translate y="0.3"/>'),
    ('<shape type="cube">{tw}<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.6, 0.3"/></bsdf></shape>',
     '<scale value="0.2"/><rotate y="1" angle="30"/><translate x="0.5" y="0.2"/>'),
]
INSTANCES = ['<translate x="-1.2"/>', '<rotate y="1" angle="70"/><scale value="1.3"/><translate x="0.3" z="-0.6"/>',
             '<rotate y="1" angle="-40"/><scale value="0.8"/><translate x="1.3" z="0.5"/>']


def test_instances_render_as_the_shapes_placed_directly(tmp_path):
    """A shapegroup of a sphere and a cube instanced three times describes and renders as the six shapes written
    out with each instance's to_world applied after the shape's own (Mitsuba's order)."""
    group = "".join(s.format(tw=f'<transform name="to_world">{t}</transform>') for s, t in GROUP_SHAPES)
    inst = "".join(f'<shape type="instance"><ref id="g"/><transform name="to_world">{t}</transform></shape>'
                   for t in INSTANCES)
    floor = '<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/>' \
            '</transform></shape>'
    a = scene_xml(tmp_path, f'<shape type="shapegroup" id="g">{group}</shape>{inst}{floor}', "a.xml")
    direct = "".join(s.format(tw=f'<transform name="to_world">{t}{i}</transform>')
                     for i in INSTANCES for s, t in GROUP_SHAPES)
    b = scene_xml(tmp_path, direct + floor, "b.xml")
    sa, sb = load(a), load(b)
    da, db = sa.describe(), sb.describe()
    for key in ("shapes", "triangles", "spheres", "lights"):
        assert da[key] == db[key], key
    assert da["spheres"] == 3 and da["shapes"] == 8  # 3 spheres, 3 cubes, the floor, the light
    assert np.allclose(da["bounds"], db["bounds"], atol=1e-5)
    ia, ib = render(sa, spp=16, seed=3), render(sb, spp=16, seed=5)
    assert not regions_agree(ia, ib)
    # Without the instances the group adds nothing.
    c = scene_xml(tmp_path, f'<shape type="shapegroup" id="g">{group}</shape>{floor}', "c.xml")
    assert load(c).describe()["shapes"] == 2


def test_instances_and_checkerboards_export_to_json(tmp_path):
    """`caustica export` of a scene with instances (names longer than a line of the JSON file) and a checkerboard
    (a 2 x 2 nearest-texel image with a uv transform) reads back as the same scene: the same image, seed for seed."""
    write_serialized(tmp_path / "m.serialized", [sheet()])
    checker = ('<bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><transform name="to_uv">'
               '<scale value="3"/><rotate z="1" angle="25"/></transform></texture></bsdf>')
    f = scene_xml(tmp_path, f"""<shape type="shapegroup" id="a_group_with_a_long_name_{'x' * 60}">
      <shape type="serialized"><string name="filename" value="m.serialized"/>{checker}</shape>
      <shape type="cylinder"><float name="radius" value="0.2"/></shape></shape>
      <shape type="instance"><ref id="a_group_with_a_long_name_{'x' * 60}"/></shape>
      <shape type="instance"><ref id="a_group_with_a_long_name_{'x' * 60}"/>
        <transform name="to_world"><translate x="1"/></transform></shape>""")
    out = tmp_path / "exported.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        caustica.export_scene(str(f), str(out))
    a, b = load(f), load(out)
    assert a.describe()["shapes"] == b.describe()["shapes"] == 5  # two instances of two shapes, the light
    np.testing.assert_array_equal(render(a, spp=4, seed=2), render(b, spp=4, seed=2))


@pytest.mark.parametrize("body,message", [
    ('<shape type="shapegroup" id="g"><shape type="rectangle"><emitter type="area"/></shape></shape>',
     "an emitter inside a shapegroup is not supported"),
    ('<shape type="shapegroup" id="g"><shape type="shapegroup" id="h"/></shape>', "a shapegroup inside a shapegroup"),
    ('<shape type="shapegroup"><shape type="cube"/></shape>', "a shapegroup needs an id"),
    ('<shape type="instance"><transform name="to_world"><translate x="1"/></transform></shape>',
     'an instance takes one <ref id="..."/> to a shapegroup'),
    ('<bsdf type="diffuse" id="d"/><shape type="instance"><ref id="d"/></shape>',
     "id 'd' is a BSDF"),
    ('<shape type="shapegroup" id="g"><shape type="sphere"/></shape><shape type="instance"><ref id="g"/>'
     '<transform name="to_world"><scale x="2"/></transform></shape>', "scales the sphere"),
    ('<shape type="shapegroup" id="g"><shape type="cube"/><bsdf type="diffuse"/></shape>', "unexpected"),
    ('<shape type="cylinder"><float name="radius" value="0"/></shape>', "expected a positive radius"),
    ('<shape type="cylinder"><point name="p1" x="0" y="0" z="0"/></shape>', "p0 and p1 are the same point"),
    ('<shape type="cone"/>', "unsupported shape type (supported: obj, ply, serialized, rectangle, cube, disk, sphere, "
                             "cylinder, shapegroup, instance)"),
])
def test_bad_groups_and_shapes_are_one_line_errors(tmp_path, body, message):
    f = scene_xml(tmp_path, body)
    with pytest.raises(caustica.InputError) as e:
        load(f)
    assert message in str(e.value) and str(e.value).startswith(f"{f}:"), str(e.value)


ORTHO = """<sensor type="orthographic"><transform name="to_world"><scale value="{half}"/>
  <lookat origin="{eye}" target="{target}" up="{up}"/></transform>
  <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/><rfilter type="box"/>
  </film></sensor>"""


def ortho_scene(tmp_path, shape, half=1.25, eye="0, 0, 5", up="0, 1, 0", target="0, 0, 0"):
    f = tmp_path / "o.xml"
    f.write_text(f'<scene version="3.0.0"><integrator type="path"><integer name="max_depth" value="1"/></integrator>'
                 f'{ORTHO.format(half=half, eye=eye, up=up, target=target)}{shape}</scene>')
    return load(f)


def test_cylinder_projected_area_and_orientation(tmp_path):
    """A cylinder light of radiance 1 from p0 to p1 seen side-on by an orthographic camera covers 2 r |p1 - p0|
    of the view, so the image mean is that over the view's area (pixel jitter makes the coverage of edge pixels
    an estimate whose standard error is computed below); it emits outwards only: with flip_normals the camera
    sees the tube's back, and the image is black."""
    r, p0, p1 = 0.4, np.array([-0.3, -0.8, 0.2]), np.array([0.5, 0.7, 0.2])  # the axis in the view plane
    length = np.linalg.norm(p1 - p0)
    cyl = ('<shape type="cylinder"><point name="p0" value="{}"/><point name="p1" value="{}"/><float name="radius" '
           'value="{}"/>{}<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>')
    pts = [", ".join(str(v) for v in p) for p in (p0, p1)]
    s = ortho_scene(tmp_path, cyl.format(*pts, r, ""), half=1.25)
    bounds = np.array(s.describe()["bounds"])
    axis = (p1 - p0) / length
    ext = r * np.sqrt(np.clip(1 - axis ** 2, 0, 1))  # a disc of radius r perpendicular to the axis, per axis
    np.testing.assert_allclose(bounds[0], np.minimum(p0, p1) - ext, atol=1e-4)
    np.testing.assert_allclose(bounds[1], np.maximum(p0, p1) + ext, atol=1e-4)
    img = render(s, spp=64, seed=1)[:, :, 0]
    expected = 2 * r * length / (2.5 * 2.5)
    mean, se = img.mean(), img.std(ddof=1) / np.sqrt(img.size)
    # Interior pixels are exactly 0 or 1; edge pixels are 64-sample estimates of their coverage. se above is
    # the spread of the pixels, an upper bound on the estimate's error; 4 of them (and the tessellation's
    # 2.5e-5 relative loss of area, far below).
    assert abs(mean - expected) < 4 * se, (mean, expected, se)
    assert ((img == 0) | (img == 1)).mean() > 0.8
    flipped = ortho_scene(tmp_path, cyl.format(*pts, r, '<boolean name="flip_normals" value="true"/>'))
    assert render(flipped, spp=4, seed=1).max() == 0


def test_cylinder_uv_follows_mitsuba(tmp_path):
    """Mitsuba's cylinder has u = phi / 2 pi about its axis (phi from the frame's s axis, which for the axis +z
    is +x) and v = z: a checkerboard radiance of one check per half turn and half height shows, looking down -y
    at the tube along +z, color1 on the lower half (v < 1/2 with u in [1/2, 1) there, phi in (pi, 2 pi)) and
    color0 on the upper half, each as a vertical band (x in [-r, r]) split at z = 1/2."""
    cyl = """<shape type="cylinder"><float name="radius" value="0.5"/>
      <emitter type="area"><texture type="checkerboard" name="radiance"><rgb name="color0" value="1, 0, 0"/>
        <rgb name="color1" value="0, 0, 1"/></texture></emitter></shape>"""
    # Camera at -y looking at +y, image up = +z: it sees the half with y < 0 (phi in (pi, 2 pi), u > 1/2).
    img = render(ortho_scene(tmp_path, cyl, half=1.0, eye="0, -5, 0.5", up="0, 0, 1",
                             target="0, 0, 0.5"), spp=16, seed=2)
    # The view spans z in [-0.5, 1.5] (rows from the top), x in [-1, 1]. Take the middle columns of the tube.
    rows_low = slice(40, 46)    # z in [0.25, 0.06]: v < 1/2
    rows_high = slice(18, 24)   # z in [0.94, 0.75]: v > 1/2
    cols = slice(26, 38)
    lo, hi = img[rows_low, cols].mean(axis=(0, 1)), img[rows_high, cols].mean(axis=(0, 1))
    # u > 1/2 and v < 1/2 are in different halves: color1; u > 1/2 and v > 1/2: color0.
    np.testing.assert_allclose(lo, [0, 0, 1], atol=1e-6)
    np.testing.assert_allclose(hi, [1, 0, 0], atol=1e-6)


def test_checkerboard_quadrants_follow_mitsuba(tmp_path):
    """Mitsuba's checkerboard is color0 where frac(u) and frac(v) lie in the same half of [0, 1). On its rectangle
    (uv (0, 0) at the corner (-1, -1) in Mitsuba's texture terms, v growing with y) seen from +z, color0 fills
    the lower-left and upper-right quadrants. A to_uv scale of 2 makes four checks across; defaults 0.4 and 0.2."""
    rect = """<shape type="rectangle"><emitter type="area"><texture type="checkerboard" name="radiance">
      <rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/>{}</texture></emitter></shape>"""
    img = render(ortho_scene(tmp_path, rect.format(""), half=1.0), spp=4, seed=1)
    q = {(i, j): img[i * 32 + 8:i * 32 + 24, j * 32 + 8:j * 32 + 24].mean(axis=(0, 1)) for i in (0, 1) for j in (0, 1)}
    red, blue = np.array([1, 0, 0]), np.array([0, 0, 1])
    np.testing.assert_allclose(q[(1, 0)], red, atol=1e-6)   # lower left (rows from the top)
    np.testing.assert_allclose(q[(0, 1)], red, atol=1e-6)   # upper right
    np.testing.assert_allclose(q[(0, 0)], blue, atol=1e-6)
    np.testing.assert_allclose(q[(1, 1)], blue, atol=1e-6)
    img = render(ortho_scene(tmp_path, rect.format('<transform name="to_uv"><scale value="2"/></transform>'),
                             half=1.0), spp=4, seed=1)
    centres = [img[i * 16 + 4:i * 16 + 12, j * 16 + 4:j * 16 + 12, 0].mean() for i in range(4) for j in range(4)]
    expected = [1.0 if (i + j) % 2 == 1 else 0.0 for i in range(4) for j in range(4)]  # lower left (3, 0) is red
    np.testing.assert_allclose(centres, expected, atol=1e-6)
    plain = """<shape type="rectangle"><emitter type="area"><texture type="checkerboard" name="radiance"/>
      </emitter></shape>"""
    img = render(ortho_scene(tmp_path, plain, half=1.0), spp=4, seed=1)
    np.testing.assert_allclose(img[40:56, 8:24].mean(axis=(0, 1)), [0.4] * 3, atol=1e-6)
    np.testing.assert_allclose(img[8:24, 8:24].mean(axis=(0, 1)), [0.2] * 3, atol=1e-6)


def test_direct_is_path_with_max_depth_2(tmp_path):
    body = """<shape type="sphere"><point name="center" x="0" y="0.8" z="0"/><float name="radius" value="0.8"/>
      </shape><shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/>
      </transform></shape>"""
    d = load(scene_xml(tmp_path, body, "d.xml", '<integrator type="direct"><integer name="emitter_samples" '
                                                 'value="2"/></integrator>'))
    assert d.integrator_defaults["integrator"] == "path" and d.integrator_defaults["max_depth"] == 2
    p = load(scene_xml(tmp_path, body, "p.xml"))
    a = render(d, spp=4, seed=1)
    np.testing.assert_array_equal(a, render(p, spp=4, seed=1, max_depth=2))
    assert a.mean() < render(p, spp=4, seed=1).mean()  # more bounces add light: the default is unlimited


@pytest.mark.parametrize("kind,depth", [("prb", 4), ("prb_basic", 4), ("prbvolpath", 4), ("prb_projective", 4),
                                        ("direct_projective", None)])
def test_differentiable_integrators_render_their_primal_image(tmp_path, kind, depth):
    """Mitsuba's differentiable integrators map to what renders their primal image: path (max_depth kept), or
    path with max depth 2 for direct_projective; projective sampling options only warn."""
    depth_xml = f'<integer name="max_depth" value="{depth}"/>' if depth else ""
    extra = '<integer name="sppc" value="8"/>' if "projective" in kind else ""
    f = scene_xml(tmp_path, "", "k.xml", f'<integrator type="{kind}">{depth_xml}{extra}</integrator>')
    with warnings.catch_warnings(record=True):
        s = caustica.load_scene(str(f))
    assert s.integrator_defaults["integrator"] == "path"
    assert s.integrator_defaults["max_depth"] == (depth or 2)
    if extra:
        assert any("sppc" in w and "ignored" in w for w in s.warnings), s.warnings


def test_ptracer_is_the_light_tracer(tmp_path):
    body = """<shape type="sphere"><point name="center" x="0" y="0.8" z="0"/><float name="radius" value="0.8"/>
      </shape>"""
    s = load(scene_xml(tmp_path, body, "t.xml", '<integrator type="ptracer"><integer name="max_depth" value="3"/>'
                                               '<integer name="samples_per_pass" value="4"/></integrator>'))
    assert s.integrator_defaults["integrator"] == "light"
    np.testing.assert_array_equal(render(s, spp=2, seed=1), render(s, integrator="light", spp=2, seed=1,
                                                                   max_depth=3))


def test_cli_renders_serialized_instances(caustica_bin, tmp_path):
    write_serialized(tmp_path / "m.serialized", [sheet()])
    f = scene_xml(tmp_path, """<shape type="shapegroup" id="g"><shape type="serialized">
      <string name="filename" value="m.serialized"/></shape></shape>
      <shape type="instance"><ref id="g"/></shape>""")
    out = tmp_path / "x.exr"
    r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "--quiet", "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    (tmp_path / "m.serialized").write_bytes(b"junk")
    r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "--quiet", "-o", str(tmp_path / "y.exr")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines()[-1].endswith("not a Mitsuba serialized mesh file (expected the identifier "
                                                      "0x041C at its start)")
