"""caustica's JSON scene format from Python and the command line: every built-in scene exports,
validates against docs/scene.schema.json, reads back to the same description and renders the
same image bit for bit; load_scene / load_dict / describe; SceneError and SceneWarning; integrator
defaults from the file; named cameras; mesh files and textures; `caustica info` and `export`."""
import json
import os
import re
import shutil
import subprocess
import warnings

import jsonschema
import numpy as np
import pytest

import caustica

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "tests", "data", "json")
SCHEMA = json.load(open(os.path.join(ROOT, "docs", "scene.schema.json")))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)
BUILTINS = [n for n, _ in caustica.builtin_scenes()]


def run(bin, *args, cwd=None):
    return subprocess.run([bin, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


def validate(doc, what):
    errors = sorted(VALIDATOR.iter_errors(doc), key=lambda e: list(e.absolute_path))
    assert not errors, f"{what}: " + "; ".join(f"/{'/'.join(map(str, e.absolute_path))}: {e.message[:200]}"
                                               for e in errors[:5])


def small(scene):
    return caustica.load_scene(scene, width=40, height=32)


def test_schema_is_valid_draft_2020_12():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert SCHEMA["$schema"] == "https://json-schema.org/draft/2020-12/schema"


@pytest.mark.parametrize("name", BUILTINS)
def test_builtin_exports_validates_and_renders_identically(name, tmp_path):
    out = tmp_path / f"{name}.json"
    caustica.export_scene(name, out)
    doc = json.loads(out.read_text())
    validate(doc, name)
    a, b = caustica.load_scene(name), caustica.load_scene(out)
    assert a.describe() == b.describe()
    assert (a.width, a.height, a.filter, a.max_depth) == (b.width, b.height, b.filter, b.max_depth)
    assert a.integrator_defaults == b.integrator_defaults
    # Exporting the exported file again gives the same text (up to the names of the files written beside it,
    # which follow the JSON's name: a density grid's "<stem>.grid0.vol").
    again = tmp_path / "again.json"
    caustica.export_scene(out, again)
    assert again.read_text().replace('"again.grid', f'"{name}.grid') == out.read_text()
    # Same seed and spp: the same image, bit for bit (the description round-trips exactly).
    ia = caustica.render(small(name), spp=2, seed=7)
    ib = caustica.render(small(out), spp=2, seed=7)
    assert ia.mean() > 0 or name == "point-in-glass"  # SDS: black for a path tracer
    assert np.array_equal(ia, ib)


def test_photon_integrator_renders_identically_after_export(tmp_path):
    out = tmp_path / "s.json"
    caustica.export_scene("point-in-glass", out)
    ia = caustica.render(small("point-in-glass"), integrator="sppm", spp=2, seed=3, photons=20000)
    ib = caustica.render(small(out), integrator="sppm", spp=2, seed=3, photons=20000)
    assert ia.mean() > 0 and np.array_equal(ia, ib)


def doc_examples():
    text = open(os.path.join(ROOT, "docs", "scene-format.md")).read()
    return re.findall(r"```json\n(.*?)```", text, re.S)


def test_docs_examples_validate_and_load(tmp_path):
    examples = doc_examples()
    assert len(examples) >= 5
    # The examples name files from tests/data/json (checker.png, sky.exr, quad.ply, tetra.obj).
    for i, ex in enumerate(examples):
        doc = json.loads(ex)
        validate(doc, f"docs example {i}")
        scene = caustica.load_dict(doc, base_dir=DATA)
        d = scene.describe()
        assert d["shapes"] >= 1, i
        img = caustica.render(caustica.load_dict(doc, base_dir=DATA, width=16, height=12), spp=1)
        assert np.isfinite(img).all() and img.mean() > 0, i
        # and the loaded example exports to a valid file that loads again
        out = tmp_path / f"ex{i}.json"
        caustica.export_scene(scene, out)
        validate(json.loads(out.read_text()), f"exported docs example {i}")
        assert caustica.load_scene(out).describe() == d


def test_schema_rejects_what_the_loader_rejects():
    base = {"camera": {}, "shapes": [{"type": "cube"}]}
    bad = [
        {"shapes": [{"type": "cube"}]},  # no camera
        dict(base, shapes=[{"type": "cube", "radius": 1}]),
        dict(base, shapes=[{"type": "mesh", "file": "a.stl"}]),
        dict(base, shapes=[{"type": "mesh", "file": "a.obj", "mesh": "m"}]),
        dict(base, materials={"m": {"type": "velvet"}}),
        dict(base, materials={"m": {"type": "diffuse", "reflectance": {"file": "x.png"}}}),
        dict(base, lights=[{"type": "spot", "target": [0, 0, 0], "direction": [0, 1, 0]}]),
        dict(base, lights=[{"type": "environment", "radiance": 1, "file": "sky.exr"}]),
        dict(base, integrator={"type": "mlt"}),
        dict(base, film={"width": 0}),
        dict(base, camera={"fov": 200}),
        dict(base, materials={"m": {"type": "diffuse", "reflectance": {"texture": "x.png", "wrap": ["clamp"]}}}),
    ]
    for doc in bad:
        assert list(VALIDATOR.iter_errors(doc)), doc
        with pytest.raises(caustica.SceneError):
            caustica.load_dict(doc)


def test_load_dict_describe_and_instances():
    tri = {"positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "indices": [0, 1, 2]}
    s = caustica.load_dict({
        "film": {"width": 30, "height": 20, "filter": "tent"},
        "camera": {"position": [0, 0, 5], "target": [0, 0, 0]},
        "materials": {"red": {"type": "diffuse", "reflectance": [0.8, 0.1, 0.1]}},
        "meshes": {"tri": tri},
        "shapes": [{"type": "mesh", "mesh": "tri", "material": "red"},
                   {"type": "mesh", "mesh": "tri", "transform": [{"scale": 2}, {"translate": [3, 0, 0]}]},
                   {"type": "sphere", "radius": 0.5, "emission": 2}],
        "lights": [{"type": "point", "position": [0, 0, 3], "intensity": 5}]})
    assert isinstance(s, caustica.Scene)
    assert (s.width, s.height, s.filter) == (30, 20, "tent")
    d = s.describe()
    assert {k: d[k] for k in ("shapes", "meshes", "triangles", "spheres", "materials", "lights", "area_lights",
                              "textures")} == dict(shapes=3, meshes=1, triangles=2, spheres=1, materials=2, lights=1,
                                                   area_lights=1, textures=0)
    lo, hi = d["bounds"]
    assert lo == pytest.approx([-0.5, -0.5, -0.5]) and hi == pytest.approx([5, 2, 0.5])
    assert caustica.describe("cornell")["area_lights"] == 1
    img = caustica.render(s, spp=1)
    assert img.shape == (20, 30, 3) and np.isfinite(img).all()


@pytest.mark.parametrize("doc,message", [
    ({"camera": {}, "shapes": [{"type": "mesh", "mesh": "nope"}]},
     "<dict>: /shapes/0/mesh: no mesh named 'nope' in /meshes (meshes: none)"),
    ({"camera": "top", "cameras": {"front": {}}, "shapes": [{"type": "cube"}]},
     "<dict>: /camera: no camera named 'top' in /cameras (cameras: front)"),
    ({"camera": {}, "shapes": [{"type": "cube", "transform": {"look_at": {"origin": [0, 0, 0], "target": [0, 0, 0]}}}]},
     "<dict>: /shapes/0/transform/look_at/target: must differ from the origin"),
    ({"camera": {}, "shapes": [{"type": "cube"}], "integrator": {"type": "mlt"}},
     "<dict>: /integrator/type: unknown integrator 'mlt' (allowed: path, sppm, ppm, pppm, pm, light, bdpt, bpm, vcm, "
     "upg, restir)"),
    ({"camera": {}, "shapes": [{"type": "cube"}], "film": {"width": 1.5}},
     "<dict>: /film/width: expected an integer, got number"),
    ({"camera": {}, "shapes": [{"type": "cube"}], "materials": {"m": {"type": "metallic_roughness", "metallic": -1}}},
     "<dict>: /materials/m/metallic: expected a number in [0, 1]"),
    ({"camera": {}, "shapes": [{"type": "cube"}],
      "materials": {"m": {"type": "diffuse", "reflectance": {"texture": "x.png", "wrap": ["repeat", "clamp", "clamp"]}}}},
     "<dict>: /materials/m/reflectance/wrap: expected a wrap mode or two ([u, v])"),
    ({"camera": {}, "shapes": [{"type": "cube"}],
      "materials": {"m": {"type": "diffuse", "reflectance": {"texture": "x.png", "wrap": ["repeat", "tile"]}}}},
     "<dict>: /materials/m/reflectance/wrap/1: unknown wrap mode 'tile' (allowed: repeat, clamp, mirror)"),
    ({"camera": {}, "shapes": [{"type": "cube"}], "lights": [{"type": "environment", "file": "gone.exr"}]},
     "<dict>: /lights/0/file: texture file 'gone.exr' does not exist"),
])
def test_load_dict_errors_are_scene_errors(doc, message):
    with pytest.raises(caustica.SceneError) as e:
        caustica.load_dict(doc)
    assert str(e.value) == message
    assert isinstance(e.value, caustica.InputError) and isinstance(e.value, ValueError)


def test_scene_error_for_files_and_names(tmp_path):
    with pytest.raises(caustica.SceneError, match="unknown scene 'nope'"):
        caustica.load_scene("nope")
    p = tmp_path / "scene.json"
    p.write_text(json.dumps({"camera": {}, "shapes": [{"type": "mesh", "file": "meshes/bunny.ply"}]}))
    with pytest.raises(caustica.SceneError) as e:
        caustica.load_scene(p)
    assert str(e.value) == (f"{p}: /shapes/0/file: mesh file 'meshes/bunny.ply' does not exist "
                            f"(looked for {tmp_path / 'meshes' / 'bunny.ply'})")
    with pytest.raises(caustica.SceneError):
        caustica.load_dict({"camera": {}, "shapes": [{"type": "cube"}], "bad": float("nan")})
    # InputError still catches scene errors, and option errors stay InputErrors (not SceneErrors).
    with pytest.raises(caustica.InputError):
        caustica.load_scene("nope")
    with pytest.raises(caustica.InputError) as e:
        caustica.render("cornell", integrator="mlt")
    assert not isinstance(e.value, caustica.SceneError)


def test_cameras_by_name(tmp_path):
    doc = {"film": {"width": 20, "height": 10},
           "cameras": {"front": {"position": [0, 0, 5], "target": [0, 0, 0]},
                       "top": {"position": [0, 5, 0], "target": [0, 0, 0], "up": [0, 0, -1], "width": 8}},
           "shapes": [{"type": "cube"}]}
    p = tmp_path / "cams.json"
    p.write_text(json.dumps(doc))
    s = caustica.load_scene(p)
    assert (s.camera, s.cameras, s.width) == ("front", ["front", "top"], 20)
    t = caustica.load_scene(p, camera="top")
    assert (t.camera, t.width, t.height) == ("top", 8, 10)
    assert caustica.load_dict(doc, camera="top").width == 8
    with pytest.raises(caustica.SceneError, match=r"no camera named 'side' \(cameras: front, top\)"):
        caustica.load_scene(p, camera="side")


def test_integrator_defaults_from_the_file(caustica_bin, tmp_path):
    doc = {"camera": {"position": [0, 0, 4], "target": [0, 0, 0], "width": 16, "height": 16},
           "integrator": {"type": "sppm", "spp": 3, "photons": 500, "alpha": 0.5, "max_depth": 4},
           "shapes": [{"type": "cube", "flip_normals": True}, {"type": "sphere", "radius": 0.3, "emission": 5}]}
    s = caustica.load_dict(doc)
    assert s.integrator_defaults == {"integrator": "sppm", "spp": 3, "photons": 500, "alpha": 0.5, "max_depth": 4}
    assert s.max_depth == 4
    r = caustica.render_job(s)
    assert r.stats["integrator"] == "sppm" and r.stats["passes"] == 3 and r.stats["photons"] == 3 * 500
    r = caustica.render_job(s, integrator="path", spp=2)  # explicit options win
    assert r.stats["integrator"] == "path" and r.stats["passes"] == 2
    r = caustica.render_job(s, time=0.2)  # a time budget replaces the file's spp
    assert r.stats["target_passes"] == 0
    # The CLI uses them too.
    p = tmp_path / "d.json"
    p.write_text(json.dumps(doc))
    out = tmp_path / "d.exr"
    res = run(caustica_bin, "render", str(p), "-o", str(out), "--quiet")
    assert res.returncode == 0, res.stderr
    assert "sppm, 3 passes" in res.stderr


def test_mesh_files_and_textures_round_trip(tmp_path):
    for f in os.listdir(DATA):
        shutil.copy(os.path.join(DATA, f), tmp_path / f)
    doc = {
        "camera": {"position": [0, -4, 2], "target": [0, 0, 0.3], "up": [0, 0, 1], "width": 40, "height": 30},
        "materials": {
            "checker": {"type": "diffuse", "reflectance": {"texture": "checker.png", "uv_scale": 4, "filter": "nearest",
                                                           "wrap": ["repeat", "mirror"]}},
            "rough": {"type": "conductor", "eta": 0.2, "k": 3, "roughness": 0.2},
            "pbr": {"type": "metallic_roughness", "base_color": [0.9, 0.6, 0.2], "metallic": 0.5, "roughness": 0.4}},
        "meshes": {"quad": {"file": "quad.ply"}, "tetra": {"file": "tetra.obj"}},
        "shapes": [
            {"type": "mesh", "mesh": "quad", "material": "checker", "transform": {"scale": 3}},
            {"type": "mesh", "mesh": "tetra", "material": "rough", "transform": {"translate": [-1, 0, 0]}},
            {"type": "mesh", "mesh": "tetra", "material": "pbr", "transform": {"translate": [0.5, 0, 0]}},
            {"type": "mesh", "file": "tetra.obj", "material": "pbr", "transform": {"translate": [0, 1, 0]}}],
        "lights": [{"type": "environment", "file": "sky.exr", "scale": 1.5,
                    "transform": {"rotate": {"axis": [1, 0, 0], "angle": 90}}}]}
    p = tmp_path / "tex.json"
    p.write_text(json.dumps(doc))
    validate(doc, "tex.json")
    s = caustica.load_scene(p)
    d = s.describe()
    assert d["textures"] == 2 and d["triangles"] == 2 + 4 + 4 + 4 and d["meshes"] == 3
    out_dir = tmp_path / "exported"
    out_dir.mkdir()
    out = out_dir / "copy.json"
    caustica.export_scene(p, out)
    assert sorted(os.listdir(out_dir)) == ["copy.json", "copy.tex0.exr", "copy.tex1.exr"]
    exported = json.loads(out.read_text())
    validate(exported, "exported tex.json")
    assert exported["materials"]["checker"]["reflectance"]["texture"] == "copy.tex0.exr"
    assert exported["materials"]["checker"]["reflectance"]["wrap"] == ["repeat", "mirror"]  # along u, along v
    assert exported["lights"][0]["file"] == "copy.tex1.exr"
    back = caustica.load_scene(out)
    assert back.describe() == dict(d, name=back.describe()["name"])
    ia = caustica.render(s, spp=2, seed=1)
    ib = caustica.render(back, spp=2, seed=1)
    # The PNG was decoded to linear floats once; the EXR keeps those floats exactly.
    assert ia.mean() > 0 and np.array_equal(ia, ib)


def test_warnings_are_python_warnings(tmp_path):
    shutil.copy(os.path.join(DATA, "tetra.obj"), tmp_path / "tetra.obj")
    with pytest.warns(caustica.SceneWarning) as rec:
        caustica.load_scene(tmp_path / "tetra.obj")
    assert [str(w.message).split(";")[0] for w in rec] == ["tetra: no camera in the file", "tetra: no lights in the file"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        caustica.load_scene("cornell")  # no warnings for a complete scene


def test_export_errors(tmp_path):
    with pytest.raises(caustica.InputError, match=r"scenes are exported as \.json"):
        caustica.export_scene("cornell", tmp_path / "x.txt")
    with pytest.raises(caustica.InputError, match="does not exist"):
        caustica.export_scene("cornell", tmp_path / "missing" / "x.json")
    with pytest.raises(caustica.SceneError, match="unknown scene"):
        caustica.export_scene("nope", tmp_path / "x.json")
    assert os.listdir(tmp_path) == []


def test_cli_info_and_export(caustica_bin, tmp_path):
    r = run(caustica_bin, "info", "smallvcm-spheres")
    assert r.returncode == 0, r.stderr
    assert re.search(r"^spheres:\s+2$", r.stdout, re.M) and re.search(r"^area_lights:\s+1$", r.stdout, re.M)
    r = run(caustica_bin, "info", "cornell", "--json")
    d = json.loads(r.stdout)
    assert d["triangles"] == 36 and d["integrator"] == {"max_depth": 8} and d["width"] == 256
    out = tmp_path / "c.json"
    r = run(caustica_bin, "export", "cornell", "-o", str(out))
    assert r.returncode == 0 and out.exists(), r.stderr
    validate(json.loads(out.read_text()), "cli export")
    img = tmp_path / "c.exr"
    r = run(caustica_bin, "render", str(out), "--spp", "1", "--width", "24", "--height", "16", "-o", str(img), "--quiet")
    assert r.returncode == 0, r.stderr
    a = caustica.read_image(img)
    assert np.array_equal(a, caustica.render(caustica.load_scene("cornell", width=24, height=16), spp=1))


def test_cli_warnings_once_and_camera_param_options(caustica_bin, tmp_path):
    shutil.copy(os.path.join(DATA, "tetra.obj"), tmp_path / "tetra.obj")
    r = run(caustica_bin, "info", str(tmp_path / "tetra.obj"))
    assert r.returncode == 0, r.stderr
    lines = [l for l in r.stderr.strip().splitlines() if l.startswith("caustica:")]
    assert lines == ["caustica: warning: tetra: no camera in the file; using a default camera looking down -z at the scene",
                     "caustica: warning: tetra: no lights in the file; using a constant white environment (radiance 1)"]
    cams = tmp_path / "cams.json"
    cams.write_text(json.dumps({"cameras": {"a": {"position": [0, 0, 5]}, "b": {"position": [0, 0, 6], "width": 9}},
                                "shapes": [{"type": "cube"}]}))
    r = run(caustica_bin, "info", str(cams), "--camera", "b", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["camera"] == "b" and json.loads(r.stdout)["width"] == 9
    r = run(caustica_bin, "export", str(cams), "--camera", "b", "-o", str(tmp_path / "b.json"))
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "b.json").read_text())["camera"] == "b"
    # --param is accepted (it substitutes Mitsuba XML $names; other formats ignore it).
    r = run(caustica_bin, "info", "cornell", "--param", "spp=4", "--param", "res=64")
    assert r.returncode == 0, r.stderr


def test_scene_desc_without_building(tmp_path):
    d = caustica.load_scene_desc("smallvcm-spheres")
    s = caustica.load_scene("smallvcm-spheres")
    assert d.describe() == s.describe() == caustica.describe("smallvcm-spheres")
    assert (d.width, d.height, d.filter, d.max_depth) == (s.width, s.height, s.filter, s.max_depth)
    out = tmp_path / "d.json"
    d.write_json(str(out))
    assert out.read_text() == d.to_json("d")
    assert np.array_equal(caustica.render(d.build(), spp=1), caustica.render(s, spp=1))
    with pytest.raises(caustica.SceneError, match="<dict>: /shapes: missing"):
        caustica.load_scene_desc({"camera": {}})


def test_export_of_a_loaded_scene_keeps_overrides(tmp_path):
    s = caustica.load_scene("cornell", width=20, height=10, filter="box")
    caustica.export_scene(s, tmp_path / "o.json")
    film = json.loads((tmp_path / "o.json").read_text())["film"]
    assert film == {"width": 20, "height": 10, "filter": "box"}
