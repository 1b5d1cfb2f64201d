"""raylink: a global-illumination renderer (Whitted ray tracing, path, light and
bidirectional path tracing, irradiance caching, illumination networks) over Embree.

Images are float32 NumPy arrays of height x width x 3 (linear RGB, top row first). A render
is a function of (scene, settings, seed): the same array, bit for bit, as the ``raylink
render`` command gives for the same scene, settings and seed.

>>> import raylink
>>> image = raylink.render("scenes/cornell-box.toml", integrator="path", spp=16,
...                        width=64, height=64, seed=1)
>>> image.shape, image.dtype
((64, 64, 3), dtype('float32'))

The settings are keywords named as the scene file's ``[render]`` settings and the command
line's options (``max_depth`` is ``--max-depth``); ``raylink.SETTINGS`` lists them. A
setting not given is the scene file's, else the technique's default.
"""

from __future__ import annotations

import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ._raylink import (
    SETTINGS,
    Cancelled,
    ProgressEvent,
    RaylinkError,
    Rendered,
    Renderer,
    Scene,
    __version__,
    check_output as _check_output,
    integrators,
    read_image,
    write_image,
)
from ._toml import dumps as _toml_dumps

__all__ = [
    "SETTINGS",
    "Cancelled",
    "ProgressEvent",
    "RaylinkError",
    "Rendered",
    "Renderer",
    "Scene",
    "__version__",
    "aovs",
    "integrators",
    "read_image",
    "relight",
    "render",
    "scene_from_dict",
    "write_image",
]

SceneLike = Union[Scene, str, "os.PathLike[str]"]
Factor = Union[float, Tuple[float, float, float]]


def scene_from_dict(description: Mapping[str, Any], base_dir: Union[str, "os.PathLike[str]"] = ".") -> Scene:
    """A scene built from a dict shaped as the native TOML format (docs/scene-format.md):
    ``camera``, ``materials`` (name to table), ``shapes`` and ``lights`` (lists of tables),
    ``world``, ``render``. It is written as TOML and read by the scene reader, which checks it
    as it checks a file; relative file names (meshes, textures) start from ``base_dir``."""
    text = _toml_dumps(description)
    return Scene.from_toml(text, os.path.join(os.fspath(base_dir), "<dict>.toml"))


def _outputs(output: Union[None, str, "os.PathLike[str]", Sequence[Any]]) -> list:
    """The paths ``output`` names, each checked before any work, as the command line does."""
    if output is None:
        return []
    outputs = [output] if isinstance(output, (str, os.PathLike)) else list(output)
    for path in outputs:
        _check_output(path)
    return outputs


def _write(rendered: Rendered, outputs: list, exposure: float, half: bool) -> None:
    for path in outputs:
        rendered.write(path, exposure=exposure, half=half)


def render(
    scene: SceneLike,
    *,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    backend: str = "embree",
    max_memory: Optional[str] = None,
    progress: Optional[Callable[[ProgressEvent], Optional[bool]]] = None,
    output: Union[None, str, "os.PathLike[str]", Sequence[Any]] = None,
    exposure: float = 0.0,
    half: bool = False,
    **settings: Any,
) -> np.ndarray:
    """Renders ``scene`` (a ``Scene`` or a scene file's path) and returns the image, float32,
    height x width x 3.

    ``settings`` are the render settings by name (``integrator="path"``, ``spp=16``,
    ``max_depth=8``, ...). ``progress(event)`` is called with the progress and, for the
    progressive techniques, the image after each pass; returning ``False`` from it stops the
    render, which returns the image so far. Ctrl-C stops it and raises ``KeyboardInterrupt``.
    ``output`` (a path or several) also writes the image, as ``raylink render -o`` does,
    with ``exposure`` (PNG, JPEG) and ``half`` (EXR). A bad scene or setting raises
    ``RaylinkError`` with the command line's one-line message."""
    outputs = _outputs(output)
    renderer = Renderer(scene, width=width, height=height, seed=seed, threads=threads,
                        backend=backend, max_memory=max_memory, **settings)
    rendered = renderer.render(progress=progress)
    _write(rendered, outputs, exposure, half)
    return rendered.image


def aovs(
    scene: SceneLike,
    *,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    backend: str = "embree",
    **settings: Any,
) -> "dict[str, np.ndarray]":
    """The auxiliary images of ``scene``'s view (``raylink render --aov``): "albedo",
    "normal" and "position" (height x width x 3), "depth", "object_id" and "material_id"
    (height x width)."""
    renderer = Renderer(scene, width=width, height=height, seed=seed, threads=threads,
                        backend=backend, **settings)
    return renderer.aovs()


def relight(
    scene: SceneLike,
    network_file: Union[str, "os.PathLike[str]"],
    lights: Optional[Mapping[str, Factor]] = None,
    *,
    store_basis: bool = False,
    reflectance_series: Sequence[str] = (),
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    output: Union[None, str, "os.PathLike[str]", Sequence[Any]] = None,
    exposure: float = 0.0,
    half: bool = False,
    **settings: Any,
) -> np.ndarray:
    """Renders ``scene`` from the illumination network saved in ``network_file`` (by a
    render with ``integrator="network", network_file=...``) with its lights changed, as
    ``raylink relight`` does: ``lights`` maps an emissive material's name to a factor, or an
    (r, g, b) of factors, for its emission. A relight that changes only light strengths adds
    up the file's light basis: no light distribution, milliseconds for a small network.
    The network options (``slopes``, ``intercept_step``, ...) must be the file's."""
    if settings.get("integrator", "network") != "network":
        raise RaylinkError("relight renders with the network integrator; leave out integrator")
    if not os.path.exists(network_file):
        raise RaylinkError(
            f"{os.fspath(network_file)}: no such network file (save one with "
            "raylink.render(..., integrator=\"network\", network_file=...))")
    settings["integrator"] = "network"
    outputs = _outputs(output)
    renderer = Renderer(
        scene, width=width, height=height, seed=seed, threads=threads,
        network_file=network_file,
        relight={"lights": dict(lights or {}), "store_basis": store_basis,
                 "reflectance_series": list(reflectance_series)},
        **settings)
    rendered = renderer.render()
    _write(rendered, outputs, exposure, half)
    return rendered.image
