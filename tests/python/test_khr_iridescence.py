"""KHR_materials_iridescence on the metallic-roughness material (material/thin_film.h, metallic_roughness.h): JSON
`iridescence`, `iridescence_eta`, `iridescence_thickness` (a number or a texture) and
`iridescence_thickness_min`; glTF iridescenceFactor, iridescenceIor, the thickness range and both textures.
A smooth film seen head-on under a white sky shows exactly the film's reflectance, which is checked here against
this file's own quadrature of the Airy reflectance over the colour matching functions; a film of thickness 0 is
no film; every integrator sees the film alike; a glTF file's film exports to JSON and renders the same. The
BSDF with a film (chi-square, weights, furnace, reciprocity) is tested in tests/cpp/test_bsdf.cpp, the film's
closed form against quadrature at many angles in tests/cpp/test_thin_film.cpp."""
import json

import numpy as np
import pytest

import caustica
from conftest import lamp_plate, region_z, seeded_region_stats, white_sky_plate
from test_clearcoat import SEEDS, export_round_trip, gltf_with
from test_khr_specular import mr

# Belcour & Barla 2017's Gaussian fits of the CIE 1931 functions in wavenumber (1/m): (V, mu, v) of the
# density V exp(-(nu - mu)^2 / (4 v)) / sqrt(2); x has two lobes.
LOBES = [(5.4856e-13, 1.6810e+06, 4.3278e+09), (9.7470e-14, 2.2399e+06, 4.5282e+09),
         (4.4201e-13, 1.7953e+06, 9.3046e+09), (5.2481e-13, 2.2084e+06, 6.6121e+09)]
XYZ_TO_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])


def film_at_normal_incidence(eta2, eta3, d_nm):
    """The film's reflectance at normal incidence per linear sRGB channel: Airy's |(a + b e^(i delta)) / (1 + a b
    e^(i delta))|^2 (both polarizations alike at normal incidence) averaged over each channel's sensitivity,
    normalized to 1, by the midpoint rule (60000 steps from 0.2e6 to 3.8e6 1/m: beyond 10 standard deviations
    of every lobe)."""
    nu = 0.2e6 + (np.arange(60000) + 0.5) * (3.6e6 / 60000)
    g = [V / np.sqrt(2) * np.exp(-(nu - mu) ** 2 / (4 * v)) for V, mu, v in LOBES]
    xyz = np.stack([g[0] + g[1], g[2], g[3]])
    dens = XYZ_TO_SRGB @ xyz
    a, b = (1 - eta2) / (1 + eta2), (eta2 - eta3) / (eta2 + eta3)
    e = np.exp(2j * np.pi * nu * 2 * eta2 * d_nm * 1e-9)
    R = np.abs((a + b * e) / (1 + a * b * e)) ** 2
    return np.clip((dens * R).sum(axis=1) / dens.sum(axis=1), 0, 1)


def mirror(**film):
    """A smooth dielectric with a black base: only the film-covered specular layer reflects."""
    return dict({"type": "metallic_roughness", "base_color": 0.0, "metallic": 0.0, "roughness": 0.0, "eta": 1.5},
                **film)


def head_on(material):
    """The mean colour of a plate of `material` seen head-on under a white sky of radiance 1 (one bounce: the
    image is the specular reflectance at cosine 1 - 3e-4 at most)."""
    img = caustica.render(white_sky_plate(material), spp=4, seed=1, max_depth=2)
    return np.asarray(img, np.float64)[..., :3].reshape(-1, 3).mean(axis=0)


@pytest.mark.parametrize("eta2,d", [(1.3, 250.0), (1.3, 400.0), (1.8, 550.0), (2.2, 900.0)])
def test_a_film_seen_head_on_reflects_airy_over_the_spectrum(eta2, d):
    """Head-on, the image is the film's reflectance over glass: this file's quadrature within 3e-4 (measured:
    8e-5 at most; the cosine is within 3.4e-4 of 1, and the renderer's closed form differs from quadrature by
    ~1e-5 at normal incidence, tests/cpp/test_thin_film.cpp). The colours differ from the bare glass's 0.04 by
    far more."""
    got = head_on(mirror(iridescence=1.0, iridescence_eta=eta2, iridescence_thickness=d))
    want = film_at_normal_incidence(eta2, 1.5, d)
    np.testing.assert_allclose(got, want, atol=3e-4)
    assert np.abs(want - 0.04).max() > 0.02


def test_the_weight_mixes_the_film_with_the_bare_fresnel():
    """Weight k: (1 - k) F + k F_film, F = 0.04 at normal incidence for IOR 1.5."""
    film = film_at_normal_incidence(1.3, 1.5, 400.0)
    got = head_on(mirror(iridescence=0.4, iridescence_eta=1.3, iridescence_thickness=400.0))
    np.testing.assert_allclose(got, 0.6 * 0.04 + 0.4 * film, atol=3e-4)


def test_a_film_of_thickness_zero_is_no_film_and_a_film_shows():
    """Thickness 0 reflects the base's Fresnel exactly (thin_film.h), so the plate renders as without a film
    (per region and channel within 4.5 standard errors); a 400 nm film differs (more than 10)."""
    def stats(material, ch):
        return seeded_region_stats(caustica.load_dict(lamp_plate(material)), SEEDS, spp=16, channel=ch)

    for ch in range(3):
        plain = stats(mr(roughness=0.3), ch)
        assert region_z(stats(mr(roughness=0.3, iridescence=1.0, iridescence_thickness=0.0), ch), plain).max() < 4.5
    assert max(region_z(stats(mr(roughness=0.3, iridescence=1.0), ch), stats(mr(roughness=0.3), ch)).max()
               for ch in range(3)) > 10


@pytest.mark.parametrize("integrator", ["light", "bdpt", "vcm"])
def test_every_integrator_sees_the_film(integrator):
    """The light tracer, BDPT and VCM agree with the path tracer per region on a rough plate with a film over
    its metal and dielectric (the film's Fresnel depends on the microfacet's cosine alone, so it is symmetric)."""
    scene = caustica.load_dict(lamp_plate(mr(roughness=0.3, metallic=0.5, iridescence=0.9,
                                             iridescence_thickness=350.0)))
    spp = 64 if integrator == "light" else 32
    ref = seeded_region_stats(scene, SEEDS, spp=32)
    got = seeded_region_stats(scene, SEEDS, integrator=integrator, spp=spp)
    assert region_z(ref, got).max() < 4.5, region_z(ref, got)


def test_a_thickness_texture_goes_from_the_minimum_to_the_scale(tmp_path):
    """A grey texel g of a thickness texture with scale 600 and minimum 100 is the thickness 100 + 500 g: the
    same head-on colour as that number (1e-5: one texel, one Fresnel evaluation)."""
    from PIL import Image
    Image.fromarray(np.full((4, 4, 3), 102, np.uint8)).save(tmp_path / "t.png")
    scene = white_sky_plate(mirror(iridescence=1.0, iridescence_thickness={"texture": str(tmp_path / "t.png"), "scale": 600},
                                   iridescence_thickness_min=100))
    img = caustica.render(scene, spp=4, seed=1, max_depth=2)
    got = np.asarray(img, np.float64)[..., :3].reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(got, head_on(mirror(iridescence=1.0, iridescence_thickness=100 + 500 * 102 / 255)),
                               atol=1e-5)


def test_gltf_iridescence_exports_and_renders_the_same(tmp_path):
    """A glTF material with KHR_materials_iridescence and both textures (no "not supported" warning) exports to
    JSON (valid against the schema), and the export renders the glTF's image exactly."""
    from PIL import Image
    import io
    rgba = np.zeros((4, 4, 4), np.uint8)
    rgba[..., 0], rgba[..., 1], rgba[..., 2], rgba[..., 3] = 230, 128, 40, 255
    buf = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buf, format="PNG")
    ext = {"iridescenceFactor": 0.9, "iridescenceIor": 1.45, "iridescenceThicknessMinimum": 120,
           "iridescenceThicknessMaximum": 650, "iridescenceTexture": {"index": 0},
           "iridescenceThicknessTexture": {"index": 0}}
    path = gltf_with(tmp_path, "KHR_materials_iridescence", ext, (0.3, 0.3, 0.3), 0.3, buf.getvalue())
    m = export_round_trip(tmp_path, path, "KHR_materials_iridescence")
    assert m["iridescence"]["scale"] == pytest.approx(0.9)
    assert m["iridescence_eta"] == pytest.approx(1.45)
    assert m["iridescence_thickness"]["scale"] == pytest.approx(650)
    assert m["iridescence_thickness_min"] == pytest.approx(120)


def test_bad_film_is_a_clear_error():
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/iridescence: expected a number in \[0, 1\]"):
        caustica.load_dict(lamp_plate(mr(iridescence=2)))
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/iridescence_eta: expected a positive number"):
        caustica.load_dict(lamp_plate(mr(iridescence=1, iridescence_eta=0)))
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/iridescence_thickness: expected a thickness >= 0"):
        caustica.load_dict(lamp_plate(mr(iridescence=1, iridescence_thickness=-5)))
    with pytest.raises(caustica.SceneError, match=r"/materials/plate/iridescence_thickness_min: expected a thickness"):
        caustica.load_dict(lamp_plate(mr(iridescence=1, iridescence_thickness_min=-1)))
