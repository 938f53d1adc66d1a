"""OpenVDB grids in heterogeneous media (scene/vdb_io.h): tests/data/media/plume.vdb, written by
tests/data/media/make_plume_vdb.cpp from a closed-form plume, reads as the dense grid that formula gives (its
active box and one voxel of background around it, placed by the file's voxel-to-world transform), renders as
the same grid given inline, exports as a .vol file, takes the medium's transform on top of the file's, and its
vec3 grid "Cd" serves as an albedo grid. A file that is not a VDB is a one-line error (exit code 2).
(tests/cpp/test_vdb.cpp compares the lookups with OpenVDB's own sampler.)"""
import json
import os
import struct

import numpy as np

import caustica
from test_media_grid import cli_render_error
from test_media_photons import fog_box

DATA = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "media")


def plume_dense():
    """make_plume_vdb.cpp's density over its active box grown by one voxel, indexed [z, y, x]: index (x, y, z)
    of the file is [z + 1, y + 1, x + 1] here."""
    d = np.zeros((22, 26, 22), np.float32)
    z, y, x = np.meshgrid(np.arange(20), np.arange(24), np.arange(20), indexing="ij")
    u, v, w = (x + 0.5) / 20 - 0.5, (y + 0.5) / 24, (z + 0.5) / 20 - 0.5
    val = 3.0 * np.exp(-(u * u + (v - 0.35) ** 2 + w * w) / 0.06) * (1.0 + 0.3 * np.sin(17 * u) * np.cos(13 * w))
    val[(x < 5) & (z < 5)] = 0.0
    val[val < 1e-3] = 0.0
    d[1:21, 1:25, 1:21] = val.astype(np.float32)
    return d


def plume_scene(density, extra=None, width=16):
    s = fog_box(width=width)
    s["media"]["fog"] = dict({"type": "heterogeneous", "sigma_t": 2.0, "albedo": 0.9, "g": 0.3,
                              "density": density}, **(extra or {}))
    return s


def test_vdb_reads_as_the_dense_grid_it_holds(tmp_path):
    # Export writes the densified grid: its samples are the formula's (float32 rounding of the same double
    # arithmetic), its transform the box [-1.15, 1.05] x [-0.15, 2.45] x [-1.15, 1.05] (index -1 to 20 / 24,
    # voxel centres at integers, voxels of 0.1, moved by (-1, 0, -1)).
    s = plume_scene({"file": os.path.join(DATA, "plume.vdb")})
    caustica.export_scene(s, str(tmp_path / "e.json"))
    m = json.loads((tmp_path / "e.json").read_text())["media"]["fog"]
    raw = (tmp_path / "e.grid0.vol").read_bytes()
    assert struct.unpack("<5i", raw[4:24]) == (1, 22, 26, 22, 1)
    got = np.frombuffer(raw[48:], "<f4").reshape(22, 26, 22)
    np.testing.assert_allclose(got, plume_dense(), rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(m["transform"]["matrix"], [2.2, 0, 0, -1.15, 0, 2.6, 0, -0.15, 0, 0, 2.2, -1.15],
                               atol=1e-5)
    # The same grid given inline (at the exported placement: a rounding's difference would send the random
    # walks elsewhere) renders the same image; so does the export.
    inline = plume_scene({"resolution": [22, 26, 22], "values": plume_dense().ravel().tolist()},
                         {"transform": m["transform"]})
    kw = dict(spp=8, seed=3, max_depth=-1)
    a = caustica.render(s, **kw)
    assert a.mean() > 0
    np.testing.assert_allclose(caustica.render(inline, **kw), a, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(caustica.render(str(tmp_path / "e.json"), **kw), a, rtol=1e-5, atol=1e-7)


def test_medium_transform_moves_the_files_world_and_cd_is_an_albedo_grid(tmp_path):
    # "transform" on a VDB medium moves the file's world space: scaled by 0.5 about the origin, the exported
    # box is half as large. The vec3 grid "Cd" (colours in [0.5, 1]) as the albedo grid renders a finite,
    # non-black image that differs from the constant albedo's.
    s = plume_scene({"file": os.path.join(DATA, "plume.vdb")}, {"transform": {"scale": 0.5}})
    caustica.export_scene(s, str(tmp_path / "e.json"))
    m = json.loads((tmp_path / "e.json").read_text())["media"]["fog"]
    np.testing.assert_allclose(m["transform"]["matrix"],
                               [1.1, 0, 0, -0.575, 0, 1.3, 0, -0.075, 0, 0, 1.1, -0.575], atol=1e-5)
    col = plume_scene({"file": os.path.join(DATA, "plume.vdb")})
    del col["media"]["fog"]["albedo"]
    col["media"]["fog"]["albedo"] = {"file": os.path.join(DATA, "plume.vdb"), "grid": "Cd"}
    kw = dict(spp=8, seed=4, max_depth=-1)
    a = caustica.render(col, **kw)
    b = caustica.render(plume_scene({"file": os.path.join(DATA, "plume.vdb")}), **kw)
    assert np.isfinite(a).all() and a.mean() > 0 and not np.allclose(a, b)
    assert caustica.describe(col)["heterogeneous_media"] == 1


def test_a_file_that_is_not_a_vdb_is_a_one_line_error(tmp_path):
    (tmp_path / "junk.vdb").write_bytes(b"not a vdb file")
    line = cli_render_error(tmp_path, plume_scene({"file": "junk.vdb"}))
    assert "s.json: /media/fog/density/file: OpenVDB file '" in line, line
    assert "junk.vdb': cannot read it" in line, line
    line = cli_render_error(tmp_path, plume_scene({"file": os.path.join(DATA, "plume.vdb"), "grid": "heat"}))
    assert "no grid named 'heat' (the file has: " in line, line
