"""Mitsuba 3 XML spectra (docs/formats-mitsuba.md, "Properties"; scene/spectrum.h): wavelength:value pairs, .spd
files, single values on emitters, and blackbodies, reduced to linear sRGB as Mitsuba 3's RGB variants reduce
them. The expected colours are what Mitsuba 3.9.1 (scalar_rgb) printed for the same properties
(`mi.traverse(mi.load_string(...))`); the loaded values are read back through `caustica.export_scene`.
bench/compare_mitsuba_xml.py renders the scene `spectral` in both renderers."""
import json
import subprocess
import warnings

import numpy as np
import pytest

import caustica

PAIRS = "400:2, 500:0.5, 700:1.5"
# Mitsuba 3.9.1's colours of PAIRS: as a reflectance (under D65, clamped to [0, 1]), unbounded (under D65:
# conductors' eta and k, constvolume values) and as an emission (no D65, unclamped).
REFLECTANCE = [1.0, 0.637601, 1.0]
UNBOUNDED = [1.26309, 0.637601, 1.23471]
EMISSION = [1.47216, 0.604087, 1.147]
# Mitsuba 3.9.1's colour of <spectrum value="1"/> on an emitter: the equal-energy white, XYZ = (1, 1, 1).
EQUAL_ENERGY = [1.20479, 0.948291, 0.908916]


def export(tmp_path, body, files=None):
    for name, text in (files or {}).items():
        (tmp_path / name).write_text(text)
    f = tmp_path / "s.xml"
    f.write_text(f'<scene version="3.0.0">\n{body}\n</scene>\n')
    out = tmp_path / "s.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        caustica.export_scene(str(f), str(out))
    return json.loads(out.read_text())


def close(got, want):
    # Mitsuba prints 6 significant digits: 1e-5 of the largest channel.
    assert np.allclose(got, want, rtol=0, atol=1e-5 * max(want)), (got, want)


def sp(name, value=PAIRS):
    return f'<spectrum name="{name}" value="{value}"/>'


def test_bsdfs_and_media_take_mitsubas_colours(tmp_path):
    j = export(tmp_path, f"""
  <bsdf type="diffuse" id="d">{sp("reflectance")}</bsdf>
  <bsdf type="conductor" id="c">{sp("eta")}{sp("k")}</bsdf>
  <medium type="homogeneous" id="a">{sp("sigma_t")}<rgb name="albedo" value="0.5"/></medium>
  <medium type="homogeneous" id="b"><volume name="sigma_t" type="constvolume">{sp("value")}</volume>
    <rgb name="albedo" value="0.25"/></medium>
  <shape type="sphere"><ref id="d"/></shape>
  <shape type="sphere"><point name="center" x="3"/><ref id="c"/></shape>
  <shape type="sphere"><point name="center" x="6"/><ref name="interior" id="a"/><bsdf type="null"/></shape>
  <shape type="sphere"><point name="center" x="9"/><ref name="interior" id="b"/><bsdf type="null"/></shape>
  <emitter type="constant"/>""")
    close(j["materials"]["d"]["reflectance"], REFLECTANCE)
    close(j["materials"]["c"]["eta"], UNBOUNDED)
    close(j["materials"]["c"]["k"], UNBOUNDED)
    # A homogeneous medium's own sigma_t is clamped to [0, 1] as a reflectance is (Mitsuba 3.9.1 does so); a
    # constvolume's value is not.
    a, b = j["media"]["a"], j["media"]["b"]
    close(np.add(a["sigma_a"], a["sigma_s"]), REFLECTANCE)
    close(np.add(b["sigma_a"], b["sigma_s"]), UNBOUNDED)
    close(b["sigma_s"], 0.25 * np.array(UNBOUNDED))


def test_emitters_take_mitsubas_colours(tmp_path):
    j = export(tmp_path, f"""
  <shape type="rectangle"><emitter type="area">{sp("radiance")}</emitter></shape>
  <shape type="rectangle"><transform name="to_world"><translate x="3"/></transform>
    <emitter type="area">{sp("radiance", "2")}</emitter></shape>
  <emitter type="point">{sp("intensity")}</emitter>
  <emitter type="spot">{sp("intensity", "0.5")}</emitter>
  <emitter type="directional">{sp("irradiance")}</emitter>
  <emitter type="constant">{sp("radiance", "3")}</emitter>""")
    area = [s["emission"] for s in j["shapes"] if s.get("emission")]
    close(area[0], EMISSION)
    close(area[1], 2 * np.array(EQUAL_ENERGY))
    lights = {l["type"]: l for l in j["lights"]}
    close(lights["point"]["intensity"], EMISSION)
    close(lights["spot"]["intensity"], 0.5 * np.array(EQUAL_ENERGY))
    close(lights["directional"]["irradiance"], EMISSION)
    close(lights["environment"]["radiance"], 3 * np.array(EQUAL_ENERGY))


def test_rgb_and_single_values_stay_as_they_are(tmp_path):
    # Mitsuba converts only <spectrum>s: <rgb> and <float> on emitters, and single-valued spectra elsewhere,
    # are used as they are; type="uniform" too.
    j = export(tmp_path, f"""
  <bsdf type="diffuse" id="d">{sp("reflectance", "0.3")}</bsdf>
  <bsdf type="diffuse" id="u"><spectrum name="reflectance" type="uniform"><float name="value" value="0.7"/></spectrum></bsdf>
  <shape type="sphere"><ref id="d"/></shape>
  <shape type="sphere"><point name="center" x="3"/><ref id="u"/></shape>
  <emitter type="point"><rgb name="intensity" value="3"/></emitter>
  <emitter type="directional"><float name="irradiance" value="2"/></emitter>""")
    close(j["materials"]["d"]["reflectance"], [0.3] * 3)
    close(j["materials"]["u"]["reflectance"], [0.7] * 3)
    lights = {l["type"]: l for l in j["lights"]}
    close(lights["point"]["intensity"], [3.0] * 3)
    close(lights["directional"]["irradiance"], [2.0] * 3)


def test_spd_file_is_the_same_spectrum(tmp_path):
    spd = "# wavelength value\n400 2\n\n500 0.5   # a comment\n700 1.5\n"
    j = export(tmp_path, """
  <bsdf type="diffuse" id="d"><spectrum name="reflectance" filename="r.spd"/></bsdf>
  <shape type="sphere"><ref id="d"/></shape>
  <emitter type="point"><spectrum name="intensity" filename="r.spd"/></emitter>""", {"r.spd": spd})
    close(j["materials"]["d"]["reflectance"], REFLECTANCE)
    close(j["lights"][0]["intensity"], EMISSION)


def test_blackbody_is_plancks_law(tmp_path):
    # type="blackbody" (which Mitsuba's RGB variants refuse to render; its spectral variants render Planck's law
    # in W m^-2 sr^-1 nm^-1) equals Planck's law written out here as 1 nm pairs: the pairs' linear interpolation
    # is within 1e-6 of the curve, so 1e-5 of the largest channel.
    h, c, k = 6.62607015e-34, 299792458.0, 1.380649e-23
    for kelvin in (2000.0, 10000.0):
        nm = np.arange(360.0, 831.0)
        lam = nm * 1e-9
        planck = 1e-9 * 2 * h * c * c / lam ** 5 / np.expm1(h * c / (lam * k * kelvin))
        pairs = ", ".join(f"{w:g}:{v:.10g}" for w, v in zip(nm, planck))
        j = export(tmp_path, f"""
  <emitter type="point"><spectrum name="intensity" type="blackbody"><float name="temperature" value="{kelvin}"/></spectrum></emitter>
  <emitter type="directional"><spectrum name="irradiance" value="{pairs}"/></emitter>""")
        lights = {l["type"]: l for l in j["lights"]}
        close(lights["point"]["intensity"], lights["directional"]["irradiance"])
        r, g, b = lights["point"]["intensity"]
        assert (r > g > b) if kelvin < 5000 else (b > g > r)  # red at 2000 K, blue at 10000 K


def test_out_of_gamut_spectra_are_clamped_with_a_warning(tmp_path):
    f = tmp_path / "s.xml"
    f.write_text(f'<scene version="3.0.0"><shape type="sphere"><bsdf type="diffuse">{sp("reflectance")}</bsdf>'
                 '</shape><emitter type="constant"/></scene>')
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        caustica.load_scene(str(f))
    msgs = [str(x.message) for x in w]
    assert any("s.xml:1: <spectrum name=\"reflectance\">: the spectrum's linear sRGB (1.26309, 0.637601, 1.23471) "
               "lies outside [0, 1]; clamped as Mitsuba 3 does" in m for m in msgs), msgs


@pytest.mark.parametrize("prop,files,message", [
    (sp("reflectance", "500:0.3"), {},
     "a spectrum needs at least two wavelength:value pairs (or one value for a flat one)"),
    (sp("reflectance", "500:0.3, 400:0.2"), {}, "the wavelengths must increase (500 then 400)"),
    (sp("reflectance", "400:0.3, 500"), {}, "expected wavelength:value pairs, got '400:0.3, 500'"),
    ('<spectrum name="reflectance" filename="r.spd"/>', {"r.spd": "400 0.2\n450 x\n"},
     "spectrum file '{d}/r.spd' line 2: expected a wavelength and a value, got '450 x'"),
    ('<spectrum name="reflectance" filename="none.spd"/>', {}, "spectrum file '{d}/none.spd' does not exist"),
    ('<spectrum name="reflectance" filename="r.spd" value="0.5"/>', {"r.spd": "400 1\n500 1\n"},
     "give either value or filename, not both"),
    ('<spectrum name="reflectance" type="d65"/>', {},
     "unsupported spectrum type 'd65' (supported: uniform, blackbody; or value=\"wavelength:value, ...\" or "
     "filename=\"*.spd\")"),
    ('<spectrum name="reflectance" type="blackbody"><float name="temperature" value="3000"/></spectrum>', {},
     "a blackbody spectrum is an emission: it is accepted for an emitter's radiance, intensity or irradiance only"),
])
def test_bad_spectra_are_one_line_errors(tmp_path, prop, files, message):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    f = tmp_path / "s.xml"
    f.write_text(f'<scene version="3.0.0">\n<shape type="sphere"><bsdf type="diffuse">\n{prop}\n</bsdf></shape>\n'
                 '</scene>\n')
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(str(f))
    assert str(e.value).startswith(f"{f}:3: <spectrum "), str(e.value)
    assert str(e.value).endswith(": " + message.format(d=tmp_path)), str(e.value)


def test_blackbody_needs_a_temperature(tmp_path):
    f = tmp_path / "s.xml"
    f.write_text('<scene version="3.0.0">\n<emitter type="point">\n'
                 '<spectrum name="intensity" type="blackbody"/>\n</emitter>\n</scene>\n')
    with pytest.raises(caustica.InputError) as e:
        caustica.load_scene(str(f))
    assert str(e.value) == (f'{f}:3: <spectrum type="blackbody" name="intensity">: missing <float '
                            'name="temperature"> (kelvin)')


def test_cli_exits_2_on_a_bad_spectrum(caustica_bin, tmp_path):
    f = tmp_path / "s.xml"
    f.write_text(f'<scene version="3.0.0">\n<emitter type="point">{sp("intensity", "600:1, 500:1")}</emitter>\n'
                 '</scene>\n')
    r = subprocess.run([caustica_bin, "render", str(f), "-o", str(tmp_path / "o.exr")], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines()[-1] == (f'caustica: error: {f}:2: <spectrum name="intensity">: the wavelengths must '
                                                 'increase (600 then 500)')
    assert "Traceback" not in r.stderr
