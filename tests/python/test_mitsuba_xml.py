"""Mitsuba 3 XML scenes from Python and the command line: Mitsuba's cornell_box() written as
XML renders like the built-in `cornell`; parameters; bad files give one line (InputError in
Python, exit status 2 from the CLI)."""
import os
import subprocess
import warnings

import numpy as np
import pytest

import caustica

from conftest import mean_and_se

DATA = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "mitsuba")
CORNELL = os.path.join(DATA, "cornell.xml")


def load(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return caustica.load_scene(path, **kw)


def render(scene, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return caustica.render(scene, **kw)


def test_cornell_xml_describes_the_builtin():
    x, b = load(CORNELL).describe(), load("cornell").describe()
    for key in ("shapes", "meshes", "triangles", "spheres", "materials", "lights", "area_lights"):
        assert x[key] == b[key], key
    assert np.allclose(x["bounds"], b["bounds"], atol=1e-5)


def test_cornell_xml_renders_like_the_builtin():
    """Same scene, same seed: per 8x8-pixel region and channel, the means agree within 4
    standard errors (the spread of the region's pixels bounds the noise from above)."""
    kw = dict(width=64, height=64)
    # The same sampler for both (the XML's own default is Mitsuba's independent sampler).
    a = render(load(CORNELL, **kw), spp=8, seed=3, sampler="sobol")
    b = render(load("cornell", **kw), spp=8, seed=3, sampler="sobol")
    assert a.shape == b.shape == (64, 64, 3)
    assert np.all(np.isfinite(a))
    bad = []
    for i in range(0, 64, 8):
        for j in range(0, 64, 8):
            for c in range(3):
                ma, sa = mean_and_se(a[i:i + 8, j:j + 8, c])
                mb, sb = mean_and_se(b[i:i + 8, j:j + 8, c])
                if abs(ma - mb) > 4 * np.hypot(sa, sb) + 1e-6:
                    bad.append((i, j, c, ma, mb))
    assert not bad, bad
    assert abs(a.mean() - b.mean()) < 0.02 * b.mean()


def test_params_from_python():
    s = load(CORNELL, params={"res": "24", "max_depth": "2"})
    assert (s.width, s.height) == (24, 24)
    img = render(s, spp=1)
    assert img.shape == (24, 24, 3)


def test_warnings_are_reported():
    s = load(CORNELL)
    assert not any("sampler" in w for w in s.warnings)
    assert s.integrator_defaults["spp"] == 64 and s.integrator_defaults["sampler"] == "independent"
    assert not any("near_clip" in w for w in s.warnings)  # read: the sensor's clipping planes
    assert s.describe()["clip"] == pytest.approx((0.001, 100.0))


def test_bad_file_raises_input_error(tmp_path):
    f = tmp_path / "bad.xml"
    f.write_text('<scene version="3.0.0">\n  <bsdf type="velvet" id="v"/>\n</scene>\n')
    with pytest.raises(caustica.InputError) as e:
        load(str(f))
    assert str(e.value) == (f'{f}:2: <bsdf type="velvet" id="v">: unsupported BSDF type (supported: diffuse, '
                            'conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, '
                            'roughplastic, principled, twosided, normalmap, bumpmap, mask, blendbsdf, null)')
    g = tmp_path / "mesh.xml"
    g.write_text('<scene version="3.0.0">\n  <shape type="obj">\n    <string name="filename" value="gone.obj"/>\n'
                 '  </shape>\n</scene>\n')
    with pytest.raises(caustica.InputError) as e:
        load(str(g))
    assert str(e.value) == f"{g}:3: <string name=\"filename\">: mesh file '{tmp_path / 'gone.obj'}' does not exist"


def test_cli_renders_xml(caustica_bin, tmp_path):
    out = str(tmp_path / "x.pfm")
    r = subprocess.run([caustica_bin, "render", CORNELL, "--spp", "1", "--width", "16", "--height", "16",
                        "--quiet", "-o", out], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert caustica.read_image(out).shape == (16, 16, 3)


def test_cli_param(caustica_bin, tmp_path):
    out = str(tmp_path / "p.pfm")
    r = subprocess.run([caustica_bin, "render", CORNELL, "--spp", "1", "--param", "res=12", "--quiet", "-o", out],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert caustica.read_image(out).shape == (12, 12, 3)


def test_cli_bad_file_exits_2(caustica_bin, tmp_path):
    f = tmp_path / "broken.xml"
    f.write_text('<scene version="3.0.0">\n  <shape type="cube">\n</scene>\n')
    out = tmp_path / "never.exr"
    r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "-o", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines()[-1].endswith(f"{f}:3: invalid XML: Start-end tags mismatch")
    assert "Traceback" not in r.stderr
    assert not out.exists()
