"""hide_emitters (every integrator, every driver; Mitsuba's hide_emitters): emitters seen directly from the camera add
nothing, everything else stays. Leaving out the emission at the end of the camera segment draws no random numbers, so
at the same seed the full image minus the hidden one is exactly the image of paths of one segment (max_depth 1): the
area light and the environment the camera sees, and nothing of their light on the floor, in the mirror or through
the glass. A screen-filling black emitter under hide_emitters renders black; the option comes from JSON and XML
scenes and the command line."""
import subprocess

import numpy as np
import pytest

import caustica

CUDA, WHY = caustica.cuda_status()

# A floor, a mirror sphere (reflections of the light and the sky must stay), a glass sphere, an area light the
# camera sees, and a sky behind.
SCENE = {"camera": {"position": [0, 1.2, 4], "target": [0, 0.6, 0], "width": 32, "height": 24},
         "materials": {"floor": {"type": "diffuse", "reflectance": 0.6},
                       "mirror": {"type": "conductor"},
                       "glass": {"type": "dielectric", "eta": 1.5}},
         "shapes": [{"type": "rectangle", "material": "floor",
                     "transform": {"scale": 3, "rotate": {"axis": [1, 0, 0], "angle": -90}}},
                    {"type": "sphere", "center": [-0.7, 0.45, 0], "radius": 0.45, "material": "mirror"},
                    {"type": "sphere", "center": [0.7, 0.45, 0.3], "radius": 0.45, "material": "glass"},
                    {"type": "rectangle", "emission": [6, 5, 4],
                     "transform": {"scale": 0.4, "translate": [0, 1.6, -1]}}],
         "lights": [{"type": "environment", "radiance": [0.3, 0.35, 0.4]}]}

INTEGRATORS = ["path", "restir", "light", "bdpt", "bpm", "vcm", "upg", "pm", "ppm", "sppm", "pppm"]


def render(scene, **kw):
    return np.asarray(caustica.render(scene, **kw), np.float64)


def expect_hidden_is_full_less_direct(**kw):
    if kw["integrator"] == "upg":
        kw["radius"] = 0.05
    full = render(SCENE, **kw)
    hidden = render(SCENE, hide_emitters=True, **kw)
    direct = render(SCENE, max_depth=1, **kw)
    assert direct.max() > 5.0 and (direct > 0.25).mean() > 0.2  # the light and the sky, seen directly
    # Equal but for the last bits of float sums in another order: a whole term left out or kept would be at least
    # 0.3 (the sky) or the light on the floor.
    np.testing.assert_allclose(full - hidden, direct, rtol=1e-4, atol=1e-4)
    assert hidden.mean() > 0.05  # the floor's light, the reflections and refractions stay


# restir has one driver (over the backend interface), so it has no separate wavefront case.
@pytest.mark.parametrize("integrator,wavefront", [(i, False) for i in INTEGRATORS] +
                         [(i, True) for i in INTEGRATORS if i != "restir"])
def test_hidden_is_the_full_image_less_the_directly_seen_emitters(integrator, wavefront):
    expect_hidden_is_full_less_direct(integrator=integrator, spp=2, seed=3, wavefront=wavefront)


@pytest.mark.skipif(not CUDA, reason=f"no CUDA device: {WHY}")
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_cuda_hides_the_directly_seen_emitters(integrator):
    """The same on the GPU (the flag travels in the stages' parameters)."""
    expect_hidden_is_full_less_direct(integrator=integrator, spp=2, seed=3, device="cuda")


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_a_hidden_black_emitter_renders_black(integrator):
    """The camera inside a closed box of emitting walls that reflect nothing: every camera ray ends on an
    emitter, so every pixel is emission seen directly and the hidden image is 0 exactly."""
    box = {"camera": {"position": [0, 0, 0], "target": [0, 0, -1], "width": 8, "height": 8},
           "materials": {"black": {"type": "diffuse", "reflectance": 0}},
           "shapes": [{"type": "cube", "material": "black", "emission": [1, 1, 1], "flip_normals": True}]}
    kw = dict(integrator=integrator, spp=2, seed=1)
    if integrator == "upg":
        kw["radius"] = 0.05
    assert render(box, **kw).min() > 0.99
    assert render(box, hide_emitters=True, **kw).max() == 0.0


def test_scene_defaults_and_overrides(tmp_path):
    s = caustica.load_dict(dict(SCENE, integrator={"hide_emitters": True}))
    assert s.integrator_defaults["hide_emitters"] is True
    np.testing.assert_array_equal(render(s, spp=1, seed=2), render(SCENE, spp=1, seed=2, hide_emitters=True))
    np.testing.assert_array_equal(render(s, spp=1, seed=2, hide_emitters=False), render(SCENE, spp=1, seed=2))
    with pytest.raises(caustica.InputError, match="hide_emitters must be True or False"):
        render(SCENE, spp=1, hide_emitters="yes")
    with pytest.raises(caustica.InputError, match="/integrator/hide_emitters: expected true or false"):
        caustica.load_dict(dict(SCENE, integrator={"hide_emitters": 1}))
    # Exported and read back, the default stays.
    out = tmp_path / "h.json"
    caustica.export_scene(dict(SCENE, integrator={"hide_emitters": True}), str(out))
    assert caustica.load_scene(str(out)).integrator_defaults["hide_emitters"] is True
    # A Mitsuba scene's integrator.
    xml = tmp_path / "h.xml"
    xml.write_text('<scene version="3.0.0"><integrator type="path"><boolean name="hide_emitters" value="true"/>'
                   '</integrator><emitter type="constant"/><shape type="sphere"/></scene>')
    with pytest.warns(caustica.SceneWarning, match="no sensor in the file"):
        assert caustica.load_scene(str(xml)).integrator_defaults["hide_emitters"] is True


def test_cli_flag(caustica_bin, tmp_path):
    import json
    f = tmp_path / "s.json"
    f.write_text(json.dumps(SCENE))
    outs = {}
    for flag in ([], ["--hide-emitters"]):
        out = tmp_path / f"o{len(flag)}.pfm"
        r = subprocess.run([caustica_bin, "render", str(f), "--spp", "1", "--seed", "2", "--quiet", "-o", str(out)]
                           + flag, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr
        outs[len(flag)] = caustica.read_image(str(out))
    np.testing.assert_array_equal(outs[1], render(SCENE, spp=1, seed=2, hide_emitters=True))
    assert outs[0].mean() > outs[1].mean()
