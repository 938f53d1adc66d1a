#!/usr/bin/env python3
"""caustica and Mitsuba 3 render the same Mitsuba XML files; how far apart are the images?

For each scene: both renderers' path tracers at the same resolution, max_depth and spp, two seeds each.
If the scenes mean the same thing, the difference between caustica and Mitsuba is noise only, so
relMSE(caustica, Mitsuba) is about the mean of relMSE(caustica seed 1, seed 2) and relMSE(Mitsuba seed 1,
seed 2) (each is the noise of two independent renders: sigma_c^2 + sigma_m^2 against 2 sigma_c^2 and
2 sigma_m^2). The ratio is printed (1 = indistinguishable at this sample count), with the whole-image
mean of each and the worst 16x16 region's difference in standard errors (from the region's pixel spread,
which bounds the noise from above).

Scenes (written to bench/out/xml/): Mitsuba's cornell_box() (tests/data/mitsuba/cornell.xml), an
environment map with coloured quadrants and a sun over a diffuse sphere, a rough gold sphere and a floor
(checks the envmap's orientation and importance sampling), and a textured floor with a plastic sphere, a
point light and an area light, an orthographic sensor over a cube, a sphere and a floor, anisotropic rough
gold (alpha_u != alpha_v) on a rectangle, a sphere and a disk, and glass (smooth and rough dielectric spheres, a
thin dielectric pane, a copper mirror), and turned spheres (a texture and an anisotropic grain that turn with
the sphere's to_world, beside an unturned textured sphere), and bumps (Mitsuba's bumpmap on a floor, normalmap on a
gold sphere and a diffuse rectangle), and cut-outs (Mitsuba's mask with a texture of holes over a screen whose shadow
falls on the floor, and a sphere of opacity 0.5; rendered with Mitsuba's volpath, whose shadow rays pass masks), and
blends (blendbsdf with a texture weight on the floor, diffuse and rough copper on a sphere, twosided around one), and
principled (a rough dielectric, a metal and a transmissive sphere: Mitsuba's Disney BSDF, caustica's principled),
and disney (every principled lobe: sheen, clearcoat, spec_tint, flatness, anisotropy, metal and glass mixed, a
roughness texture), disney_textured (every principled weight a colour texture, read as its luminance), and beckmann (rough conductors, an anisotropic one, and a rough glass with Mitsuba's default
distribution), and spotlit (spot lights with wide falloff bands), and sides (cards with a different BSDF on each side: twosided of two BSDFs), and plastics (smooth and rough plastics, Beckmann and GGX), and foggy (homogeneous media with Mitsuba's volpath: the camera in fog bounded by a null
cube, a glass sphere of milk, a null box of smoke, a floor and an area light in the fog), and smoky (a heterogeneous medium: a gridvolume smoke plume in a turned null box), and tinted (colour grids: a
three-channel sigma_t gridvolume and a colour albedo gridvolume with a to_world of its own, beside a homogeneous
box whose albedo is a gridvolume), and instanced (serialized meshes, a shapegroup with an icosphere and a cylinder
instanced three times, a checkerboard texture with a to_uv, a cylinder light), and direct (Mitsuba's `direct`
integrator) and ptracer (Mitsuba's particle tracer; caustica renders it with its light tracer), and colored (vertex
colours through Mitsuba's mesh_attribute texture, from PLY files with float colours), and clipped (a crop window of
the film, near and far clipping planes cutting the floor, a principal point offset), and spectral (reflectances,
a conductor's eta and k, a transmittance and emitters given as wavelength:value spectra, from a .spd file and as
single values on emitters), and smoothed (a coarse sphere as PLY and OBJ files without normals, which both
renderers smooth).

caustica renders each scene with the integrator its XML names (path for path, volpath and direct; light for ptracer).
`--integrator bdpt` (or light, vcm, sppm, ...) renders caustica's side with that integrator instead, against
the same Mitsuba renders (e.g. bdpt with medium vertices on foggy, smoky and tinted against Mitsuba's volpath).

usage: .venv/bin/python bench/compare_mitsuba_xml.py [--spp 256] [--res 128] [--integrator NAME] [--only NAME ...]
       [--rows]
(needs Mitsuba 3 from PyPI: bench/install-mitsuba.sh)
"""
import argparse
import datetime
import math
import os
import sys
import warnings

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python"))
import caustica  # noqa: E402
from caustica import _provenance  # noqa: E402

OUT = os.path.join(ROOT, "bench", "out", "xml")


def relmse(a, b):
    return float(np.mean((a - b) ** 2 / (b ** 2 + 0.01)))


def row_of_spheres(sensor, max_depth, floor, spheres):
    """A scene of a 6 x 6 floor with the BSDF `floor` and three spheres of radius 0.55 at x = -1.2, 0, 1.2 with the
    BSDFs `spheres` (XML), lit by a small area light at the left and a dim sky (principled, disney, beckmann,
    plastics)."""
    balls = "".join(f"""
  <shape type="sphere"><transform name="to_world"><scale value="0.55"/><translate x="{x}" y="0.55" z="0"/></transform>
    {b}</shape>""" for x, b in zip(("-1.2", "0", "1.2"), spheres))
    return f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="{max_depth}"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    {floor}</shape>{balls}
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate z="1" angle="-70"/>
      <translate x="-3" y="1" z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="30, 28, 24"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.22, 0.25"/></emitter>
</scene>
"""


def write_scenes(res):
    os.makedirs(OUT, exist_ok=True)
    # Environment: sky gradient, coloured quadrants in u (orientation), a sun.
    h, w = 64, 128
    env = np.zeros((h, w, 3), np.float32)
    theta = (np.arange(h) + 0.5) / h * math.pi
    env[:] = (0.3 + 0.5 * np.cos(theta).clip(0))[:, None, None]
    quad = [(1.0, 0.4, 0.4), (0.4, 1.0, 0.4), (0.4, 0.4, 1.0), (1.0, 1.0, 0.4)]
    for q in range(4):
        env[:, q * w // 4:(q + 1) * w // 4] *= np.array(quad[q], np.float32)
    env[12:15, 80:83] = (300, 280, 220)
    caustica.write_image(os.path.join(OUT, "sky.exr"), env)
    tex = np.zeros((8, 8, 3), np.float32)
    tex[(np.add.outer(np.arange(8), np.arange(8)) % 2) == 0] = (0.8, 0.8, 0.8)
    tex[(np.add.outer(np.arange(8), np.arange(8)) % 2) == 1] = (0.1, 0.3, 0.6)
    caustica.write_image(os.path.join(OUT, "checker.exr"), tex)
    sensor = f"""<sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 2, 6" target="0, 0.7, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
      <rfilter type="box"/></film></sensor>"""
    # A small area light above the middle, facing down (textured, colored, direct, ptracer).
    top_light = """  <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="90"/>
      <translate y="3"/></transform>
    <emitter type="area"><rgb name="radiance" value="12, 11, 9"/></emitter></shape>"""
    with open(os.path.join(OUT, "envmap.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  {sensor}
  <emitter type="envmap"><string name="filename" value="sky.exr"/>
    <transform name="to_world"><rotate y="1" angle="30"/></transform></emitter>
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="-0.9" y="0.7" z="0"/><float name="radius" value="0.7"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.9" y="0.7" z="0"/><float name="radius" value="0.7"/>
    <bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.15"/></bsdf></shape>
</scene>
""")
    with open(os.path.join(OUT, "textured.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="checker.exr"/>
      <string name="filter_type" value="nearest"/></texture></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="0.8" z="0"/><float name="radius" value="0.8"/>
    <bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.4, 0.2"/></bsdf></shape>
{top_light}
  <emitter type="point"><point name="position" x="2" y="2" z="2"/><rgb name="intensity" value="6, 6, 8"/></emitter>
</scene>
""")
    # Orthographic sensor (its to_world scale sets the view: 2 x 2.5 units wide) looking down obliquely at
    # a red cube left-right asymmetric with a sphere (a mirrored or mis-scaled view shows), sun and sky.
    with open(os.path.join(OUT, "orthographic.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="3"/></integrator>
  <sensor type="orthographic">
    <transform name="to_world"><scale x="2.5" y="2.5"/><lookat origin="3, 4, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
      <rfilter type="box"/></film></sensor>
  <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate x="1.2" y="0.5" z="0"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="-1" y="0.6" z="0.3"/><float name="radius" value="0.6"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf></shape>
  <emitter type="directional"><vector name="direction" x="-0.3" y="-1" z="-0.5"/><rgb name="irradiance" value="3, 3, 3"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.25, 0.3"/></emitter>
</scene>
""")
    # Anisotropic roughness (alpha_u along dp/du): a brushed-gold floor, a sphere and a disk (radial dp/du in
    # Mitsuba's parameterisation) under a small area light and a dim sky; a frame that ignored dp/du, or a
    # disk or sphere parameterised differently, shows as a highlight stretched the wrong way.
    aniso = """<bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>
      <float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.35"/></bsdf>"""
    with open(os.path.join(OUT, "anisotropic.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate z="1" angle="30"/>
      <rotate x="1" angle="-90"/></transform>{aniso}</shape>
  <shape type="sphere"><point name="center" x="-0.9" y="0.7" z="0"/><float name="radius" value="0.7"/>{aniso}</shape>
  <shape type="disk"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="-60"/>
      <translate x="0.9" y="0.7" z="0"/></transform>{aniso}</shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/>
      <translate y="3" z="-1"/></transform>
    <emitter type="area"><rgb name="radiance" value="20, 18, 15"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.05, 0.06, 0.08"/></emitter>
</scene>
""")
    # Glass: a smooth dielectric sphere, a rough dielectric sphere (GGX 0.2), a thin dielectric pane and a
    # smooth copper mirror on a diffuse floor, lit by an area light and a sky (refraction, Fresnel, total
    # internal reflection and the thin slab's interreflection).
    with open(os.path.join(OUT, "glass.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="10"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="-1.1" y="0.6" z="0"/><float name="radius" value="0.6"/>
    <bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.3" y="0.6" z="0.3"/><float name="radius" value="0.6"/>
    <bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>
      <string name="int_ior" value="bk7"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale x="0.5" y="0.7"/><rotate y="1" angle="20"/>
      <translate x="1.4" y="0.7" z="-0.3"/></transform>
    <bsdf type="thindielectric"><float name="int_ior" value="1.5"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale x="1.2" y="0.8"/><translate y="0.8" z="-1.5"/></transform>
    <bsdf type="conductor"><string name="material" value="Cu"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="90"/>
      <translate y="3"/></transform>
    <emitter type="area"><rgb name="radiance" value="15, 14, 12"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.35, 0.4"/></emitter>
</scene>
""")
    # Turned spheres: a sphere's UVs are measured in its own frame, so a texture (coloured quadrants in u,
    # darker towards v = 1) and the anisotropic grain turn with its to_world's rotation; an unturned
    # textured sphere beside them checks the unrotated layout.
    quads = np.zeros((16, 32, 3), np.float32)
    for q, col in enumerate([(0.8, 0.2, 0.2), (0.2, 0.8, 0.2), (0.2, 0.2, 0.8), (0.8, 0.8, 0.2)]):
        quads[:, q * 8:(q + 1) * 8] = col
    quads[:5] *= 0.3  # the image's top rows: v near 1 in Mitsuba's uv (theta near 0, the +z pole)
    caustica.write_image(os.path.join(OUT, "quadrants.exr"), quads)
    tex_bsdf = """<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename"
      value="quadrants.exr"/><string name="filter_type" value="nearest"/></texture></bsdf>"""
    with open(os.path.join(OUT, "turned.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="-70"/>
      <rotate y="1" angle="40"/><translate x="-1.3" y="0.6" z="0"/></transform>{tex_bsdf}</shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.6"/><translate x="0" y="0.6" z="-0.4"/></transform>
    {tex_bsdf}</shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.6"/><rotate z="1" angle="60"/>
      <rotate x="1" angle="50"/><translate x="1.3" y="0.6" z="0"/></transform>{aniso}</shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="90"/>
      <translate x="1" y="3" z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="15, 14, 12"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.35, 0.4"/></emitter>
</scene>
""")
    # Bumps: a floor with a height map (raw, bilinear: Mitsuba's bumpmap) of round bumps, a sphere and a
    # rectangle with a normal map (raw: Mitsuba's normalmap) of tilted tiles over rough gold, lit from low
    # on one side so that the slopes' directions show.
    n = 64
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    height = (0.5 + 0.5 * np.sin(xx * 2 * math.pi / 16) * np.sin(yy * 2 * math.pi / 16)).astype(np.float32)
    caustica.write_image(os.path.join(OUT, "height.exr"), np.repeat(height[:, :, None], 3, axis=2))
    tiles = np.zeros((n, n, 3), np.float32)
    tx = np.where((xx // 16) % 2 == 0, 0.35, -0.35)  # tangent-space x tilt alternating per column of tiles
    ty = np.where((yy // 16) % 2 == 0, 0.25, -0.25)
    nz = np.sqrt(1 - tx ** 2 - ty ** 2)
    tiles[:, :, 0], tiles[:, :, 1], tiles[:, :, 2] = 0.5 * tx + 0.5, 0.5 * ty + 0.5, 0.5 * nz + 0.5
    caustica.write_image(os.path.join(OUT, "tiles.exr"), tiles)
    # Mitsuba >= 3.7.1 flips normals that face away from the viewer and adds a terminator shadowing term in
    # both wrappers by default; caustica does neither, so the comparison turns them off.
    plain = ('<boolean name="flip_invalid_normals" value="false"/>'
             '<boolean name="use_shadowing_function" value="false"/>')
    with open(os.path.join(OUT, "bumpy.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="bumpmap">{plain}<texture type="bitmap"><string name="filename" value="height.exr"/>
      <boolean name="raw" value="true"/></texture><float name="scale" value="0.02"/>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></bsdf></shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.7"/><translate x="-0.9" y="0.7" z="0"/></transform>
    <bsdf type="normalmap">{plain}<texture type="bitmap" name="normalmap"><string name="filename" value="tiles.exr"/>
      <boolean name="raw" value="true"/></texture>
      <bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>
        <float name="alpha" value="0.15"/></bsdf></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate y="1" angle="-30"/>
      <translate x="1" y="0.7" z="0"/></transform>
    <bsdf type="normalmap">{plain}<texture type="bitmap" name="normalmap"><string name="filename" value="tiles.exr"/>
      <boolean name="raw" value="true"/></texture>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate z="1" angle="-70"/>
      <translate x="-3" y="1" z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="30, 28, 24"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.12, 0.15"/></emitter>
</scene>
""")
    # Cut-outs: Mitsuba's mask over a leaf-like screen (a texture of holes, solid and half-opaque bands) that
    # casts its pattern onto the floor, and a sphere of opacity 0.5 whose inside shows. volpath: Mitsuba's
    # path integrator lets no shadow ray through a mask (a screen of opacity 0.4 over a floor under a
    # directional light renders 0 there; volpath 0.1799, the analytic 0.18, caustica 0.18).
    holes = np.ones((n, n), np.float32)
    holes[((xx % 16) - 8) ** 2 + ((yy % 16) - 8) ** 2 < 25] = 0.0
    holes[:, 40:48] = 0.5
    caustica.write_image(os.path.join(OUT, "holes.exr"), np.repeat(holes[:, :, None], 3, axis=2))
    with open(os.path.join(OUT, "masked.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.9"/><rotate x="1" angle="-60"/>
      <translate x="0.6" y="1.4" z="0.3"/></transform>
    <bsdf type="mask"><texture type="bitmap" name="opacity"><string name="filename" value="holes.exr"/>
      <string name="filter_type" value="nearest"/></texture>
      <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.6, 0.15"/></bsdf></bsdf></bsdf></shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.6"/><translate x="-1" y="0.6" z="0"/></transform>
    <bsdf type="mask"><float name="opacity" value="0.5"/>
      <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.4, 0.1"/></bsdf></bsdf></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/>
      <translate x="0.5" y="3.5" z="0.5"/></transform>
    <emitter type="area"><rgb name="radiance" value="30, 28, 24"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.12, 0.15"/></emitter>
</scene>
""")
    # Blends: Mitsuba's blendbsdf of grey diffuse and rough gold on the floor, weighted by a texture (the
    # bumps' height map, its luminance), and of blue diffuse and rough copper (weight 0.3) on a sphere, beside
    # a twosided blend of green and white diffuse on a rectangle. Not a smooth (delta) BSDF in a blend: Mitsuba
    # 3.9.1's blendbsdf loses part of it (a sphere of blend(diffuse 0.2, mirror; 0.3) under a constant sky of 1
    # renders 0.342 in Mitsuba where 0.7 x 0.2 + 0.3 x 1 = 0.44, its own renders of either BSDF averaged give
    # 0.4399, and caustica gives 0.4416; with a rough conductor instead both renderers match their averages).
    with open(os.path.join(OUT, "blended.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="blendbsdf"><texture type="bitmap" name="weight"><string name="filename" value="height.exr"/>
      <boolean name="raw" value="true"/></texture>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf>
      <bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>
        <float name="alpha" value="0.2"/></bsdf></bsdf></shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.7"/><translate x="-0.9" y="0.7" z="0"/></transform>
    <bsdf type="blendbsdf"><float name="weight" value="0.3"/>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.2, 0.7"/></bsdf>
      <bsdf type="roughconductor"><string name="material" value="Cu"/><string name="distribution" value="ggx"/>
        <float name="alpha" value="0.1"/></bsdf></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate y="1" angle="-30"/>
      <translate x="1" y="0.7" z="0"/></transform>
    <bsdf type="twosided"><bsdf type="blendbsdf"><float name="weight" value="0.6"/>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.6, 0.1"/></bsdf>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.9, 0.9, 0.9"/></bsdf></bsdf></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate z="1" angle="-70"/>
      <translate x="-3" y="1" z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="30, 28, 24"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.22, 0.25"/></emitter>
</scene>
""")
    # principled (Mitsuba's Disney BSDF) as caustica's metallic-roughness material: a rough red dielectric, a
    # rough gold-coloured metal and a rough transmissive sphere on a principled floor.
    with open(os.path.join(OUT, "principled.xml"), "w") as f:
        f.write(row_of_spheres(sensor, 6, """<bsdf type="principled"><rgb name="base_color" value="0.5, 0.5, 0.5"/><float name="roughness" value="0.8"/></bsdf>""", [
            """<bsdf type="principled"><rgb name="base_color" value="0.7, 0.1, 0.05"/><float name="roughness" value="0.3"/></bsdf>""",
            """<bsdf type="principled"><rgb name="base_color" value="1.0, 0.78, 0.34"/><float name="metallic" value="1"/>
      <float name="roughness" value="0.25"/></bsdf>""",
            """<bsdf type="principled"><rgb name="base_color" value="0.9, 0.95, 1.0"/><float name="spec_trans" value="1"/>
      <float name="roughness" value="0.2"/><float name="eta" value="1.5"/></bsdf>"""]))
    # Mitsuba's default microfacet distribution, Beckmann: rough gold, an anisotropic rough copper and a rough
    # glass sphere, none naming its distribution.
    with open(os.path.join(OUT, "beckmann.xml"), "w") as f:
        f.write(row_of_spheres(sensor, 8, """<bsdf type="roughconductor"><string name="material" value="Al"/><float name="alpha" value="0.3"/></bsdf>""", [
            """<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.15"/></bsdf>""",
            """<bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha_u" value="0.05"/>
      <float name="alpha_v" value="0.4"/></bsdf>""",
            """<bsdf type="roughdielectric"><float name="alpha" value="0.2"/><float name="int_ior" value="1.5"/></bsdf>"""]))
    # Plastics: smooth, and rough with Mitsuba's default (Beckmann) and GGX coats (caustica's roughplastic mapping,
    # docs/formats-mitsuba.md: the base is dimmed by the smooth coat's Fresnel terms, not the rough coat's).
    with open(os.path.join(OUT, "plastics.xml"), "w") as f:
        f.write(row_of_spheres(sensor, 6, """<bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.5"/><float name="alpha" value="0.3"/></bsdf>""", [
            """<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.7, 0.2, 0.1"/></bsdf>""",
            """<bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.1, 0.5, 0.2"/><float name="alpha" value="0.15"/>
      </bsdf>""",
            """<bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.2, 0.3, 0.8"/><float name="alpha" value="0.4"/>
      <string name="distribution" value="ggx"/></bsdf>"""]))
    # Spot lights with wide falloff bands (beam_width well inside cutoff_angle) on a floor and a sphere: the
    # falloff curve is the difference.
    with open(os.path.join(OUT, "spotlit.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.6" y="0.5" z="-0.3"/><float name="radius" value="0.5"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.5, 0.7"/></bsdf></shape>
  <emitter type="spot"><transform name="to_world"><lookat origin="-1, 3, 1" target="-0.5, 0, 0" up="0, 0, 1"/></transform>
    <float name="cutoff_angle" value="35"/><float name="beam_width" value="5"/><rgb name="intensity" value="25, 22, 18"/></emitter>
  <emitter type="spot"><transform name="to_world"><lookat origin="2, 2.5, 1.5" target="0.6, 0.3, -0.3" up="0, 1, 0"/></transform>
    <float name="cutoff_angle" value="25"/><float name="beam_width" value="12"/><rgb name="intensity" value="10, 14, 20"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.05"/></emitter>
</scene>
""")
    # Cards with a different BSDF on each side (twosided of two BSDFs), turned so that the camera sees some
    # fronts and some backs, and light reaches both sides of each (a point light on one side, the sky all round).
    card = """  <shape type="rectangle"><transform name="to_world"><scale x="0.45" y="0.6"/><rotate y="1" angle="{a}"/>
    <translate x="{x}" y="0.6" z="{z}"/></transform>
    <bsdf type="twosided">{front}{back}</bsdf></shape>"""
    cards = "\n".join(card.format(a=a, x=x, z=z, front=fr, back=bk) for a, x, z, fr, bk in [
        (30, -1.0, 0.0, '<bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.15, 0.1"/></bsdf>',
         '<bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.2, 0.8"/></bsdf>'),
        (20, 0.0, -0.2, '<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.2"/></bsdf>',
         '<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.7, 0.2"/></bsdf>'),
        (-140, 1.0, 0.1, '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.7, 0.7, 0.2"/></bsdf>',
         '<bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.6, 0.2, 0.6"/><float name="alpha" value="0.2"/></bsdf>')])
    with open(os.path.join(OUT, "sides.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
{cards}
  <emitter type="point"><point name="position" x="0.5" y="2.5" z="2"/><rgb name="intensity" value="6"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
</scene>
""")
    # Every principled lobe: sheen with tint, clearcoat, spec_tint, flatness, anisotropy, a half-metal
    # half-glass, and a roughness texture (the checker's green) on the floor.
    with open(os.path.join(OUT, "disney.xml"), "w") as f:
        f.write(row_of_spheres(sensor, 6, """<bsdf type="principled"><rgb name="base_color" value="0.6, 0.55, 0.5"/><float name="clearcoat" value="1"/>
      <float name="clearcoat_gloss" value="0.8"/>
      <texture type="bitmap" name="roughness"><string name="filename" value="checker.exr"/>
        <transform name="to_uv"><scale value="4"/></transform></texture></bsdf>""", [
            """<bsdf type="principled"><rgb name="base_color" value="0.8, 0.2, 0.5"/><float name="roughness" value="0.7"/>
      <float name="sheen" value="1"/><float name="sheen_tint" value="0.6"/><float name="flatness" value="0.5"/>
      </bsdf>""",
            """<bsdf type="principled"><rgb name="base_color" value="0.3, 0.5, 0.9"/><float name="metallic" value="0.6"/>
      <float name="roughness" value="0.35"/><float name="anisotropic" value="0.8"/><float name="spec_tint" value="0.7"/>
      <float name="specular" value="0.9"/></bsdf>""",
            """<bsdf type="principled"><rgb name="base_color" value="0.95, 0.8, 0.6"/><float name="spec_trans" value="0.7"/>
      <float name="metallic" value="0.2"/><float name="roughness" value="0.25"/><float name="eta" value="1.4"/>
      <float name="clearcoat" value="0.5"/></bsdf>"""]))
    # Every principled weight as a texture (the colour checker, which both renderers read as its luminance).
    def weights(*keys, scale=4):
        return "".join(f"""<texture type="bitmap" name="{k}"><string name="filename" value="checker.exr"/>
        <transform name="to_uv"><scale value="{scale}"/></transform></texture>""" for k in keys)
    with open(os.path.join(OUT, "disney_textured.xml"), "w") as f:
        f.write(row_of_spheres(sensor, 6, f"""<bsdf type="principled"><rgb name="base_color" value="0.6, 0.55, 0.5"/>
      <float name="clearcoat" value="1"/>{weights("roughness", "metallic", "clearcoat_gloss")}</bsdf>""", [
            f"""<bsdf type="principled"><rgb name="base_color" value="0.8, 0.2, 0.5"/><float name="roughness" value="0.7"/>
      {weights("sheen", "sheen_tint", "flatness", scale=2)}</bsdf>""",
            f"""<bsdf type="principled"><rgb name="base_color" value="0.3, 0.5, 0.9"/><float name="roughness" value="0.35"/>
      {weights("metallic", "spec_tint", "clearcoat", scale=2)}</bsdf>""",
            f"""<bsdf type="principled"><rgb name="base_color" value="0.95, 0.8, 0.6"/><float name="roughness" value="0.25"/>
      {weights("spec_trans", scale=2)}</bsdf>"""]))
    # Media (Mitsuba's volpath): the camera inside fog (a null cube bounds it; the sky lights it through the
    # boundary), a glass sphere of milk (interior) in the fog (exterior), a null box of forward-scattering
    # smoke (lifted off the floor: a face coplanar with the floor is resolved differently by the two
    # renderers), a diffuse floor and an area light, both in the fog.
    fog_sensor = sensor.replace("<film", '<ref id="fog"/>\n    <film', 1)
    with open(os.path.join(OUT, "foggy.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="16"/></integrator>
  <medium type="homogeneous" id="fog"><rgb name="sigma_t" value="0.06, 0.08, 0.1"/>
    <float name="albedo" value="0.9"/><phase type="hg"><float name="g" value="0.5"/></phase></medium>
  <medium type="homogeneous" id="milk"><rgb name="sigma_t" value="0.5, 0.75, 1"/><float name="scale" value="4"/>
    <rgb name="albedo" value="0.98, 0.95, 0.9"/><phase type="hg"><float name="g" value="0.3"/></phase></medium>
  <medium type="homogeneous" id="smoke"><float name="sigma_t" value="1.5"/>
    <float name="albedo" value="0.8"/><phase type="hg"><float name="g" value="0.7"/></phase></medium>
  {fog_sensor}
  <shape type="cube"><transform name="to_world"><scale value="8"/></transform><bsdf type="null"/>
    <ref name="interior" id="fog"/></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf><ref name="exterior" id="fog"/></shape>
  <shape type="sphere"><transform name="to_world"><scale value="0.6"/><translate x="-0.8" y="0.6" z="0"/></transform>
    <bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf>
    <ref name="interior" id="milk"/><ref name="exterior" id="fog"/></shape>
  <shape type="cube"><transform name="to_world"><scale x="0.4" y="0.6" z="0.4"/><translate x="0.9" y="0.65" z="0"/></transform>
    <bsdf type="null"/><ref name="interior" id="smoke"/><ref name="exterior" id="fog"/></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate z="1" angle="-70"/>
      <translate x="-3" y="1" z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="30, 28, 24"/></emitter><ref name="exterior" id="fog"/></shape>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.22, 0.25"/></emitter>
</scene>
""")
    # The media scenes' stage: a diffuse floor, an area light and the sky.
    stage = """  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate z="1" angle="-70"/>
      <translate x="-3" y="1" z="1"/></transform>
    <emitter type="area"><rgb name="radiance" value="30, 28, 24"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.22, 0.25"/></emitter>
"""
    # A heterogeneous medium (Mitsuba's heterogeneous with a gridvolume sigma_t): a lopsided smoke plume (dense
    # low on one side, a rippled haze above) in a null box turned about y, over a diffuse floor, lit by an area
    # light and the sky. The grid is written in Mitsuba's .vol format beside the XML.
    n = 24
    c = (np.arange(n) + 0.5) / n
    gz, gy, gx = np.meshgrid(c, c, c, indexing="ij")
    dens = (4.0 * np.exp(-((gx - 0.35) ** 2 + (gy - 0.3) ** 2 + (gz - 0.5) ** 2) / 0.03)
            + 0.6 * np.clip(gy, 0, 1) * (1 + np.sin(12 * gx) * np.cos(9 * gz)))
    dens[:, :, : n // 8] = 0.0  # an empty slab on one side
    with open(os.path.join(OUT, "smoke.vol"), "wb") as f:
        f.write(b"VOL" + bytes([3]) + np.array([1, n, n, n, 1], "<i4").tobytes()
                + np.array([0, 0, 0, 1, 1, 1], "<f4").tobytes() + dens.astype("<f4").tobytes())
    with open(os.path.join(OUT, "smoky.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="16"/></integrator>
  <medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume"><string name="filename" value="smoke.vol"/>
      <transform name="to_world"><translate value="-0.5, 0, -0.5"/><scale x="2.4" y="1.8" z="2.4"/>
        <rotate y="1" angle="30"/><translate y="0.01"/></transform></volume>
    <rgb name="albedo" value="0.95, 0.9, 0.8"/><float name="scale" value="4"/>
    <phase type="hg"><float name="g" value="0.4"/></phase></medium>
  {sensor}
  <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate value="0.5, 0.5, 0.5"/>
      <translate value="-0.5, 0, -0.5"/><scale x="2.4" y="1.8" z="2.4"/><rotate y="1" angle="30"/>
      <translate y="0.01"/></transform>
    <bsdf type="null"/><ref name="interior" id="smoke"/></shape>
{stage}</scene>
""")
    # Colour grids (Mitsuba's three-channel sigma_t gridvolume and albedo gridvolumes): a plume whose
    # channels differ (red dense low on one side, blue spread higher), its albedo a 4 x 4 x 4 colour grid
    # (greenish below, reddish above) with a to_world of its own; beside it a homogeneous box whose albedo
    # is a gridvolume (white on one side, dark blue on the other).
    red = dens
    blue = 0.5 * np.roll(dens, n // 4, axis=1) + 0.5
    green = 0.5 * (red + blue)
    colour = np.stack([red, green, blue], axis=-1)
    k = (np.arange(4) + 0.5) / 4
    az, ay, ax = np.meshgrid(k, k, k, indexing="ij")
    albedo = np.stack([0.5 + 0.45 * ay, 0.95 - 0.4 * ay, 0.6 + 0.3 * ax], axis=-1)
    side = np.array([[[[0.95, 0.95, 0.95], [0.1, 0.2, 0.6]]]])

    def write_vol(name, v):
        nz, ny, nx, ch = v.shape
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(b"VOL" + bytes([3]) + np.array([1, nx, ny, nz, ch], "<i4").tobytes()
                    + np.array([0, 0, 0, 1, 1, 1], "<f4").tobytes() + v.astype("<f4").tobytes())

    write_vol("tinted_sigma_t.vol", colour)
    write_vol("tinted_albedo.vol", albedo)
    write_vol("side_albedo.vol", side)
    with open(os.path.join(OUT, "tinted.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="volpath"><integer name="max_depth" value="16"/></integrator>
  <medium type="heterogeneous" id="smoke">
    <volume name="sigma_t" type="gridvolume"><string name="filename" value="tinted_sigma_t.vol"/>
      <transform name="to_world"><translate value="-0.5, 0, -0.5"/><scale x="2.4" y="1.8" z="2.4"/>
        <rotate y="1" angle="30"/><translate x="-0.5" y="0.01"/></transform></volume>
    <volume name="albedo" type="gridvolume"><string name="filename" value="tinted_albedo.vol"/>
      <transform name="to_world"><translate value="-0.5, 0, -0.5"/><scale x="2" y="1.6" z="2"/>
        <translate x="-0.6" y="0.1"/></transform></volume>
    <float name="scale" value="3"/>
    <phase type="hg"><float name="g" value="0.4"/></phase></medium>
  <medium type="homogeneous" id="side">
    <rgb name="sigma_t" value="1, 0.8, 0.6"/><float name="scale" value="2.5"/>
    <volume name="albedo" type="gridvolume"><string name="filename" value="side_albedo.vol"/>
      <transform name="to_world"><translate value="1.2, 0.3, -0.4"/><scale x="0.8" y="0.8" z="0.8"/></transform></volume>
  </medium>
  {sensor}
  <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate value="0.5, 0.5, 0.5"/>
      <translate value="-0.5, 0, -0.5"/><scale x="2.4" y="1.8" z="2.4"/><rotate y="1" angle="30"/>
      <translate x="-0.5" y="0.01"/></transform>
    <bsdf type="null"/><ref name="interior" id="smoke"/></shape>
  <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate value="0.5, 0.5, 0.5"/>
      <translate value="1.2, 0.3, -0.4"/><scale x="0.8" y="0.8" z="0.8"/></transform>
    <bsdf type="null"/><ref name="interior" id="side"/></shape>
{stage}</scene>
""")
    # Serialized meshes, shapegroups and instances, cylinders and a checkerboard: a floor from a serialized file
    # (with UVs, under a checkerboard with a to_uv), and a shapegroup (a serialized icosphere without normals,
    # smoothed by both renderers, and a rough-gold cylinder) instanced three times, turned and scaled; a
    # cylinder light; Mitsuba's `direct` integrator (max depth 2).
    sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
    from serialized_mesh import write_serialized
    t = (1 + 5 ** 0.5) / 2
    ico = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                    (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)], np.float64)
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
             (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
             (8, 6, 7), (9, 8, 1)]
    verts = [tuple(v / np.linalg.norm(v)) for v in ico]
    for _ in range(2):  # two subdivisions: 320 triangles
        cache, nf = {}, []
        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                m = np.add(verts[a], verts[b])
                verts.append(tuple(m / np.linalg.norm(m)))
                cache[k] = len(verts) - 1
            return cache[k]
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nf
    floor = dict(positions=[(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)], indices=[(0, 2, 1), (0, 3, 2)],
                 normals=[(0, 1, 0)] * 4, uvs=[(0, 0), (1, 0), (1, 1), (0, 1)], name="floor")
    write_serialized(os.path.join(OUT, "meshes.serialized"),
                     [floor, dict(positions=verts, indices=faces, name="ball")])
    with open(os.path.join(OUT, "instanced.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="5"/></integrator>
  {sensor}
  <shape type="serialized"><string name="filename" value="meshes.serialized"/>
    <transform name="to_world"><scale value="3"/></transform>
    <bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.8, 0.8, 0.7"/>
      <rgb name="color1" value="0.2, 0.3, 0.5"/><transform name="to_uv"><scale value="4"/><rotate z="1" angle="20"/>
      </transform></texture></bsdf></shape>
  <shape type="shapegroup" id="thing">
    <shape type="serialized"><string name="filename" value="meshes.serialized"/><integer name="shape_index" value="1"/>
      <transform name="to_world"><scale value="0.35"/><translate y="0.35"/></transform>
      <bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.6, 0.15, 0.1"/></bsdf></shape>
    <shape type="cylinder"><point name="p0" x="0.5" y="0" z="0"/><point name="p1" x="0.5" y="0.9" z="0.1"/>
      <float name="radius" value="0.15"/>
      <bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>
        <float name="alpha" value="0.2"/></bsdf></shape>
  </shape>
  <shape type="instance"><ref id="thing"/><transform name="to_world"><translate x="-1.2"/></transform></shape>
  <shape type="instance"><ref id="thing"/><transform name="to_world"><rotate y="1" angle="70"/>
    <scale value="1.3"/><translate x="0.2" z="-0.6"/></transform></shape>
  <shape type="instance"><ref id="thing"/><transform name="to_world"><rotate y="1" angle="-40"/>
    <scale x="0.8" y="1.2" z="0.8"/><translate x="1.3" z="0.5"/></transform></shape>
  <shape type="cylinder"><point name="p0" x="-1.5" y="2.5" z="-1"/><point name="p1" x="1.5" y="2.5" z="-1"/>
    <float name="radius" value="0.06"/><emitter type="area"><rgb name="radiance" value="40, 36, 30"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.12, 0.15"/></emitter>
</scene>
""")
    # Vertex colours through Mitsuba's mesh_attribute texture: an icosphere with colours from its position and a
    # floor with a gradient, PLY files with float colours, under an area light and a dim sky.
    # (Mitsuba 3.9.1 reads past a serialized file's colours, so both meshes are PLY files.)
    with open(os.path.join(OUT, "colored_ball.ply"), "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(verts)}\nproperty float x\nproperty float y\n"
                "property float z\nproperty float red\nproperty float green\nproperty float blue\n"
                f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for v in verts:
            f.write(" ".join(f"{x:.7g}" for x in list(v) + [0.15 + 0.7 * abs(c) for c in v]) + "\n")
        for a, b, c in faces:
            f.write(f"3 {a} {b} {c}\n")
    with open(os.path.join(OUT, "colored_floor.ply"), "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                "property float red\nproperty float green\nproperty float blue\nelement face 2\n"
                "property list uchar int vertex_indices\nend_header\n"
                "-3 0 -3 0.9 0.2 0.1\n3 0 -3 0.1 0.8 0.2\n3 0 3 0.1 0.2 0.9\n-3 0 3 0.9 0.9 0.9\n3 0 2 1\n3 0 3 2\n")
    attr = '<texture type="mesh_attribute" name="{}"><string name="name" value="vertex_color"/>{}</texture>'
    with open(os.path.join(OUT, "colored.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="5"/></integrator>
  {sensor}
  <shape type="ply"><string name="filename" value="colored_floor.ply"/>
    <bsdf type="diffuse">{attr.format("reflectance", '<float name="scale" value="0.8"/>')}</bsdf></shape>
  <shape type="ply"><string name="filename" value="colored_ball.ply"/>
    <transform name="to_world"><scale value="0.8"/><translate y="0.8"/></transform>
    <bsdf type="diffuse">{attr.format("reflectance", "")}</bsdf></shape>
{top_light}
  <emitter type="constant"><rgb name="radiance" value="0.15, 0.15, 0.2"/></emitter>
</scene>
""")
    with open(os.path.join(OUT, "direct.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="direct"/>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="0.8" z="0"/><float name="radius" value="0.8"/>
    <bsdf type="roughconductor"><string name="material" value="Cu"/><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.1"/></bsdf></shape>
{top_light}
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.2, 0.25"/></emitter>
</scene>
""")
    with open(os.path.join(OUT, "ptracer.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="ptracer"><integer name="max_depth" value="4"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="0.8" z="0"/><float name="radius" value="0.8"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.3"/></bsdf></shape>
{top_light}
</scene>
""")
    # Spectra (Mitsuba's wavelength:value pairs, a .spd file, single values on emitters: docs/formats-mitsuba.md).
    nm = np.arange(380, 781, 20)
    leaf = 0.05 + 0.45 * np.exp(-0.5 * ((nm - 550) / 30.0) ** 2) + 0.5 / (1 + np.exp(-(nm - 710) / 12.0))
    with open(os.path.join(OUT, "leaf.spd"), "w") as f:
        f.write("# a leaf-like reflectance: a green peak and the red edge\n")
        f.write("".join(f"{w} {v:.4f}\n" for w, v in zip(nm, leaf)))
    with open(os.path.join(OUT, "spectral.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="400:0.2, 450:0.6, 500:0.75, 600:0.7, 700:0.65"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-2" y="1"/></transform>
    <bsdf type="diffuse"><spectrum name="reflectance" value="400:0.05, 560:0.08, 600:0.6, 700:0.85"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="-0.9" y="0.6" z="0"/><float name="radius" value="0.6"/>
    <bsdf type="diffuse"><spectrum name="reflectance" filename="leaf.spd"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.9" y="0.6" z="0"/><float name="radius" value="0.6"/>
    <bsdf type="roughconductor"><spectrum name="eta" value="400:1.5, 500:0.9, 600:0.27, 700:0.16"/>
      <spectrum name="k" value="400:1.9, 500:1.8, 600:2.9, 700:3.9"/><float name="alpha" value="0.15"/>
      <string name="distribution" value="ggx"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="0.4" z="1.1"/><float name="radius" value="0.4"/>
    <bsdf type="dielectric"><spectrum name="specular_transmittance" value="400:0.3, 480:0.9, 560:0.5, 700:0.2"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="90"/>
      <translate y="3"/></transform>
    <emitter type="area"><spectrum name="radiance" value="400:4, 500:9, 600:12, 700:14"/></emitter></shape>
  <emitter type="point"><point name="position" x="-2" y="2.5" z="2"/><spectrum name="intensity" value="3"/></emitter>
  <emitter type="constant"><spectrum name="radiance" value="360:0.3, 830:0.1"/></emitter>
</scene>
""")
    # Missing normals: a coarse UV sphere (10 segments, 6 rings; poles fanned, quads split along alternating
    # diagonals) as a PLY and an OBJ file without normals, smoothed by the loader (angle-weighted, as Mitsuba).
    seg, rings = 10, 6
    sv = [(0.0, 1.0, 0.0)] + [(math.sin(math.pi * r / rings) * math.cos(2 * math.pi * k / seg),
                               math.cos(math.pi * r / rings),
                               math.sin(math.pi * r / rings) * math.sin(2 * math.pi * k / seg))
                              for r in range(1, rings) for k in range(seg)] + [(0.0, -1.0, 0.0)]
    ring = lambda r, k: 1 + (r - 1) * seg + k % seg  # noqa: E731
    sf = [(0, ring(1, k + 1), ring(1, k)) for k in range(seg)]
    for r in range(1, rings - 1):
        for k in range(seg):
            a, b, c, d = ring(r, k), ring(r, k + 1), ring(r + 1, k + 1), ring(r + 1, k)
            sf += [(a, b, c), (a, c, d)] if (r + k) % 2 else [(a, b, d), (b, c, d)]
    sf += [(len(sv) - 1, ring(rings - 1, k), ring(rings - 1, k + 1)) for k in range(seg)]
    with open(os.path.join(OUT, "smooth_ball.ply"), "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {len(sv)}\nproperty float x\nproperty float y\n"
                f"property float z\nelement face {len(sf)}\nproperty list uchar int vertex_indices\nend_header\n")
        f.write("".join(" ".join(f"{x:.7g}" for x in v) + "\n" for v in sv))
        f.write("".join(f"3 {a} {b} {c}\n" for a, b, c in sf))
    with open(os.path.join(OUT, "smooth_ball.obj"), "w") as f:
        f.write("".join("v " + " ".join(f"{x:.7g}" for x in v) + "\n" for v in sv))
        f.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in sf))
    with open(os.path.join(OUT, "smoothed.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="5"/></integrator>
  {sensor}
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <shape type="ply"><string name="filename" value="smooth_ball.ply"/>
    <transform name="to_world"><scale value="0.7"/><translate x="-0.8" y="0.7"/></transform>
    <bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.1"/>
      <string name="distribution" value="ggx"/></bsdf></shape>
  <shape type="obj"><string name="filename" value="smooth_ball.obj"/>
    <transform name="to_world"><rotate y="1" angle="20"/><scale value="0.7"/><translate x="0.8" y="0.7"/></transform>
    <bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.2, 0.4, 0.7"/></bsdf></shape>
{top_light}
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.3, 0.35"/></emitter>
</scene>
""")
    # Crop window and clipping planes: the film's middle-right quarter, the floor's near part cut away by the near
    # plane (the sky below shows through) and its far part by the far plane; spheres between them; the principal
    # point moved right and up.
    c0, c1, cw = res * 5 // 16, res * 3 // 16, res // 2
    with open(os.path.join(OUT, "clipped.xml"), "w") as f:
        f.write(f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  <sensor type="perspective"><float name="fov" value="40"/><float name="near_clip" value="4.5"/>
    <float name="far_clip" value="8"/><float name="principal_point_offset_x" value="0.08"/>
    <float name="principal_point_offset_y" value="-0.06"/>
    <transform name="to_world"><lookat origin="0, 2, 6" target="0, 0.7, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
      <integer name="crop_offset_x" value="{c0}"/><integer name="crop_offset_y" value="{c1}"/>
      <integer name="crop_width" value="{cw}"/><integer name="crop_height" value="{cw}"/>
      <rfilter type="gaussian"/></film></sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="checker.exr"/>
      <string name="filter_type" value="nearest"/></texture></bsdf></shape>
  <shape type="sphere"><point name="center" x="-0.6" y="0.6" z="0"/><float name="radius" value="0.6"/>
    <bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.7, 0.3, 0.2"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.8" y="0.5" z="-0.5"/><float name="radius" value="0.5"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.6, 0.8"/></bsdf></shape>
{top_light}
  <emitter type="constant"><rgb name="radiance" value="0.3, 0.3, 0.35"/></emitter>
</scene>
""")
    return {"cornell": os.path.join(ROOT, "tests", "data", "mitsuba", "cornell.xml"),
            "envmap": os.path.join(OUT, "envmap.xml"), "textured": os.path.join(OUT, "textured.xml"),
            "orthographic": os.path.join(OUT, "orthographic.xml"), "anisotropic": os.path.join(OUT, "anisotropic.xml"),
            "glass": os.path.join(OUT, "glass.xml"), "turned": os.path.join(OUT, "turned.xml"),
            "bumpy": os.path.join(OUT, "bumpy.xml"), "masked": os.path.join(OUT, "masked.xml"),
            "blended": os.path.join(OUT, "blended.xml"), "principled": os.path.join(OUT, "principled.xml"),
            "disney": os.path.join(OUT, "disney.xml"), "disney_textured": os.path.join(OUT, "disney_textured.xml"),
            "beckmann": os.path.join(OUT, "beckmann.xml"),
            "spotlit": os.path.join(OUT, "spotlit.xml"), "sides": os.path.join(OUT, "sides.xml"),
            "plastics": os.path.join(OUT, "plastics.xml"),
            "foggy": os.path.join(OUT, "foggy.xml"), "smoky": os.path.join(OUT, "smoky.xml"),
            "tinted": os.path.join(OUT, "tinted.xml"), "instanced": os.path.join(OUT, "instanced.xml"),
            "direct": os.path.join(OUT, "direct.xml"), "ptracer": os.path.join(OUT, "ptracer.xml"),
            "colored": os.path.join(OUT, "colored.xml"), "spectral": os.path.join(OUT, "spectral.xml"),
            "smoothed": os.path.join(OUT, "smoothed.xml"), "clipped": os.path.join(OUT, "clipped.xml")}


def render_caustica(path, res, spp, seed, integrator=None):
    """integrator None: the one the XML names (path for path/volpath/direct, light for ptracer)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = caustica.load_scene(path, width=res, height=res)
        return np.asarray(caustica.render(s, integrator=integrator, spp=spp, seed=seed), np.float64)


def render_mitsuba(path, res, spp, seed):
    import mitsuba as mi
    scene = mi.load_file(path, res=res) if "cornell" in path else mi.load_file(path)
    img = mi.render(scene, spp=spp, seed=seed)
    return np.asarray(img, np.float64)[:, :, :3]


def worst_region(c, m):
    """Largest |mean_c - mean_m| over 16x16 regions and channels in standard errors, each region's
    standard error from its pixels' spread (an upper bound on the noise: the spread includes the
    image's own structure)."""
    n = c.shape[0] // 16

    def stats(x):
        r = x[:n * 16, :n * 16].reshape(n, 16, n, 16, 3)
        return r.mean(axis=(1, 3)), r.std(axis=(1, 3), ddof=1) / 16.0

    mc, sc = stats(c)
    mm, sm = stats(m)
    return float((np.abs(mc - mm) / np.sqrt(sc ** 2 + sm ** 2 + 1e-12)).max())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--rows", action="store_true", help="print bench/RESULTS.md rows")
    ap.add_argument("--only", nargs="*", help="render only these scenes (names as printed)")
    ap.add_argument("--integrator", default=None,
                    help="caustica's integrator (default: the XML's, as caustica maps it: path, or light for ptracer)")
    args = ap.parse_args()
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb" if "llvm_ad_rgb" in mi.variants() else "scalar_rgb")
    scenes = write_scenes(args.res)
    commit = _provenance.commit(ROOT)
    machine = _provenance.machine()
    rows = []
    for name, path in scenes.items():
        if args.only and name not in args.only:
            continue
        c1, c2 = (render_caustica(path, args.res, args.spp, s, args.integrator) for s in (1, 2))
        m1, m2 = (render_mitsuba(path, args.res, args.spp, s) for s in (1, 2))
        noise = relmse(c1, c2)
        cross = relmse(c1, m1)
        mnoise = relmse(m1, m2)
        worst = worst_region(c1, m1)
        ratio = cross / (0.5 * (noise + mnoise))
        print(f"{name:9s} mean caustica {c1.mean():.4f} mitsuba {m1.mean():.4f}  relMSE(c,m) {cross:.5f}  "
              f"relMSE(c1,c2) {noise:.5f}  relMSE(m1,m2) {mnoise:.5f}  ratio {ratio:.2f}  "
              f"worst 16x16 region {worst:.1f} standard errors")
        how = "" if args.integrator is None else f" --integrator {args.integrator}"
        rows.append(f"| {datetime.date.today()} | {machine} | {commit} | `bench/compare_mitsuba_xml.py --spp "
                    f"{args.spp} --res {args.res}{how}` | {name}: mean {c1.mean():.4f} vs Mitsuba {mi.__version__} "
                    f"{m1.mean():.4f}; relMSE(caustica, Mitsuba) / mean relMSE(two seeds of each) = "
                    f"{ratio:.2f}; worst 16x16 region {worst:.1f} standard errors |")
        caustica.write_image(os.path.join(OUT, f"{name}_caustica.exr"), c1.astype(np.float32))
        caustica.write_image(os.path.join(OUT, f"{name}_mitsuba.exr"), m1.astype(np.float32))
    if args.rows:
        print("\n".join(rows))


if __name__ == "__main__":
    main()
