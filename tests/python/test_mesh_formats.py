"""OBJ + MTL and PLY files through the Python API and the command line: they load and render, the same
quad from OBJ and from PLY renders to the same image, MTL lights and textures take effect, and broken files
give one line on stderr and exit status 2. Files are written into pytest's temporary folder."""
import json
import struct
import subprocess

import numpy as np
import pytest

import caustica

QUAD_OBJ = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n"


def quad_ply(fmt):
    verts = [(-1, -1, 0, 0, 0), (1, -1, 0, 1, 0), (1, 1, 0, 1, 1), (-1, 1, 0, 0, 1)]
    head = ("ply\nformat %s 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
            "property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n" % fmt).encode()
    if fmt == "ascii":
        body = "".join("%g %g %g %g %g\n" % v for v in verts) + "4 0 1 2 3\n"
        return head + body.encode()
    e = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(struct.pack(e + "5f", *v) for v in verts) + struct.pack(e + "B4i", 4, 0, 1, 2, 3)
    return head + body


def run(bin, *args):
    return subprocess.run([bin, *args], capture_output=True, text=True, timeout=120)


def render(path, **kw):
    return caustica.render(caustica.load_scene(str(path), width=24, height=24), spp=4, **kw)


def test_obj_and_ply_quads_render_identically(tmp_path):
    (tmp_path / "q.obj").write_text(QUAD_OBJ)
    ref = render(tmp_path / "q.obj")
    assert ref.shape == (24, 24, 3) and np.isfinite(ref).all() and ref.mean() > 0.05
    for fmt in ("ascii", "binary_little_endian", "binary_big_endian"):
        p = tmp_path / f"q_{fmt}.ply"
        p.write_bytes(quad_ply(fmt))
        assert np.array_equal(render(p), ref), fmt


def test_mtl_light_and_texture(tmp_path):
    # A floor with an 8x1 texture (left half black, right half white) lit by an emissive quad that faces
    # down beside it (symmetric in x, out of the floor's way in the image).
    pfm = b"PF\n8 1\n-1.0\n" + struct.pack("<24f", *([0.0] * 12 + [1.0] * 12))
    (tmp_path / "bw.pfm").write_bytes(pfm)
    (tmp_path / "room.mtl").write_text("newmtl floor\nKd 0.5 0.5 0.5\nmap_Kd bw.pfm\nnewmtl lamp\nKd 0 0 0\nKe 5 5 5\n")
    (tmp_path / "room.obj").write_text(
        "mtllib room.mtl\n"
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "g floor\nusemtl floor\nf 1/1 2/2 3/3 4/4\n"
        "v -0.5 1.5 1\nv 0.5 1.5 1\nv 0.5 2.5 1\nv -0.5 2.5 1\ng lamp\nusemtl lamp\nf 5 8 7 6\n")
    scene = caustica.load_scene(str(tmp_path / "room.obj"), width=48, height=48)
    img = caustica.render(scene, spp=16)
    # Lit by the lamp only (no default environment): the floor's white half is bright, its black half dark.
    left, right = img[26:36, 18:22].mean(), img[26:36, 26:30].mean()
    assert right > 0.02 and left < 0.1 * right, (left, right)


def test_mtl_pbr_extension_is_gltfs_metallic_roughness(tmp_path):
    """The MTL PBR extension (Pr, Pm, Pc, Pcr beside Kd; the Ks, Ns and illum exporters write with them are not
    read) gives the material a glTF file with the same values gets: their JSON exports are the same material,
    and the quad renders the same under the default camera and environment."""
    from test_gltf import Gltf
    (tmp_path / "gold.mtl").write_text("newmtl gold\nKd 1 0.8 0.3\nKs 0.5 0.5 0.5\nNs 300\nillum 2\n"
                                       "Pr 0.3\nPm 0.75\nPc 0.5\nPcr 0.2\n")
    (tmp_path / "gold.obj").write_text("mtllib gold.mtl\nusemtl gold\n" + QUAD_OBJ)
    g = Gltf()
    mat = g.add("materials", {"name": "gold", "pbrMetallicRoughness": {
        "baseColorFactor": [1, 0.8, 0.3, 1], "metallicFactor": 0.75, "roughnessFactor": 0.3},
        "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 0.5, "clearcoatRoughnessFactor": 0.2}}})
    g.scene([g.add("nodes", {"mesh": g.quad(mat)})])
    gltf = g.write(tmp_path / "gold.gltf")
    with pytest.warns(caustica.SceneWarning):  # no camera, no lights: the defaults, with warnings
        from_obj, from_gltf = (json.loads(caustica.load_scene_desc(p).to_json()) for p in (tmp_path / "gold.obj", gltf))
    assert list(from_obj["materials"].values()) == list(from_gltf["materials"].values())
    with pytest.warns(caustica.SceneWarning):
        a, b = render(tmp_path / "gold.obj"), render(gltf)
    np.testing.assert_array_equal(a, b)


def test_cli_renders_obj_and_ply(caustica_bin, tmp_path):
    (tmp_path / "q.obj").write_text(QUAD_OBJ)
    (tmp_path / "q.ply").write_bytes(quad_ply("binary_little_endian"))
    for name in ("q.obj", "q.ply"):
        out = tmp_path / (name + ".png")
        r = run(caustica_bin, "render", str(tmp_path / name), "--spp", "4", "--width", "16", "--height", "16",
                "--quiet", "-o", str(out))
        assert r.returncode == 0, r.stderr
        assert out.read_bytes()[:4] == b"\x89PNG"


BAD = [
    ("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1200\n",
     "a.obj: line 4: vertex index 1200 out of range (3 vertices defined so far)"),
    ("b.obj", "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "b.obj: line 1: material library 'gone.mtl' not found ("),
    ("c.obj", "v 0 0 0\n", "c.obj: no faces (1 vertex and no 'f' statements)"),
    ("d.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty flt x\n", "d.ply: line 4 (header): unknown property type 'flt'"),
    ("e.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n",
     "e.ply: line 13: face 0: vertex index 9 out of range (3 vertices)"),
    ("f.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" + b"\0" * 20,
     "f.ply: truncated binary data: vertex 1 ends past the end of the file"),
]


@pytest.mark.parametrize("name,content,needle", BAD, ids=[b[0] for b in BAD])
def test_cli_bad_mesh_files(caustica_bin, tmp_path, name, content, needle):
    p = tmp_path / name
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content)
    r = run(caustica_bin, "render", str(p), "--spp", "1", "-o", str(tmp_path / "x.png"))
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert needle in lines[0] and str(tmp_path) in lines[0], lines[0]
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "x.png").exists()
    with pytest.raises(caustica.InputError, match="^" + str(p).replace(".", r"\.")):
        caustica.load_scene(str(p))
