"""caustica: physically based global illumination.

    import caustica
    scene = caustica.load_scene("cornell")
    image = caustica.render(scene, integrator="path", spp=64)   # (H, W, 3) float32
    caustica.write_image("cornell.exr", image)

    scene = caustica.load_scene("scene.json")       # or .obj/.ply/.gltf/.glb/.xml, or load_dict({...})
    scene.describe()                                 # counts and bounds
    caustica.export_scene("cornell", "cornell.json")  # any scene as caustica JSON
"""
from ._api import (
    InputError,
    RenderError,
    RenderResult,
    Scene,
    SceneError,
    SceneWarning,
    __version__,
    builtin_scenes,
    cuda_status,
    default_scene_name,
    describe,
    devices,
    export_scene,
    integrators,
    load_dict,
    load_scene,
    load_scene_desc,
    read_image,
    render,
    render_job,
    write_image,
)
from . import metrics  # image metrics: caustica.metrics.relmse, .flip, .evaluate (docs/metrics.md)
from . import study  # caustica.study.realtime(...): spp and frame time for a FLIP target (docs/realtime-study.md)
from .converge import converge

__all__ = [
    "InputError", "RenderError", "RenderResult", "Scene", "SceneError", "SceneWarning", "__version__", "builtin_scenes",
    "cuda_status", "default_scene_name", "describe",
    "devices", "export_scene", "integrators", "load_dict", "load_scene", "load_scene_desc", "read_image",
    "render", "render_job", "write_image", "metrics", "converge",
]
