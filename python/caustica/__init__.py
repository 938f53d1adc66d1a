"""caustica: physically based global illumination.

    import caustica
    scene = caustica.load_scene("cornell")
    image = caustica.render(scene, integrator="path", spp=64)   # (H, W, 3) float32
    caustica.write_image("cornell.exr", image)
"""
from ._api import (
    InputError,
    RenderResult,
    __version__,
    builtin_scenes,
    default_scene_name,
    integrators,
    load_scene,
    read_image,
    render,
    render_job,
    write_image,
)

__all__ = [
    "InputError", "RenderResult", "__version__", "builtin_scenes", "default_scene_name", "integrators",
    "load_scene", "read_image", "render", "render_job", "write_image",
]
