"""Type hints of the extension module (the classes and functions `raylink` re-exports)."""

import os
import pathlib
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
SETTINGS: List[str]

_Path = Union[str, "os.PathLike[str]"]
_Image = npt.NDArray[np.float32]

class RaylinkError(Exception):
    """A render, scene, setting or image the library refused or could not finish; the
    message is the command line's one line."""

class Cancelled(RaylinkError):
    """Work cancelled (by a progress callback) in a phase with nothing to keep."""

class ProgressEvent:
    """What a progress callback is given."""

    phase: str
    """The phase: "building", "overture", "preprocess", "distribution", "render", ..."""
    done: int
    """Units of the phase done (the library's own units: tiles, passes, nodes)."""
    total: Optional[int]
    """Units in the phase, if known."""
    spp: Optional[int]
    """After a pass of a progressive render: the samples per pixel so far."""
    image: Optional[_Image]
    """After a pass: the image so far (float32, height x width x 3)."""
    elapsed: float
    """Seconds since the work started."""

Callback = Callable[[ProgressEvent], Optional[bool]]

class Scene:
    """A scene read from a file (`.toml`, `.pbrt`) or from TOML text."""

    @staticmethod
    def load(path: _Path) -> Scene:
        """Reads a scene file, choosing the reader by extension."""
    @staticmethod
    def from_toml(text: str, path: Optional[_Path] = None) -> Scene:
        """Reads a native TOML scene from `text`; `path` names it in messages and is where
        relative file names start from."""
    @property
    def width(self) -> int:
        """The camera's image width in pixels."""
    @property
    def height(self) -> int:
        """The camera's image height in pixels."""
    @property
    def materials(self) -> List[str]:
        """The materials' names (the lights `relight` scales are the emissive ones)."""
    @property
    def source(self) -> "pathlib.Path":
        """The file the scene was read from."""

class Rendered:
    """The image of a render, with its statistics."""

    image: _Image
    """float32, height x width x 3, linear RGB, top row first."""
    partial: bool
    """Whether the render was cancelled before every sample was taken."""
    samples: int
    """Camera samples taken."""
    seconds: float
    """Seconds the render took (its preparation not included)."""
    prepare_seconds: float
    """Seconds the technique's preparation took in this render."""
    summary: str
    """The statistics as the command line prints them."""
    def write(
        self, path: _Path, *, exposure: float = 0.0, half: bool = False, color_space: str = "srgb"
    ) -> None:
        """Writes the image (EXR, HDR, TIFF, PNG, JPEG by extension) with its metadata, as
        the command line's outputs; `color_space` ("srgb", "rec2020", "dci-p3",
        "aces2065-1") is the linear formats' RGB."""

class Renderer:
    """A render job and the engine that runs it: the intersection structure and the
    technique's preparation are made once and serve every render after."""

    def __init__(
        self,
        scene: Union[Scene, _Path],
        *,
        width: Optional[int] = None,
        height: Optional[int] = None,
        seed: int = 0,
        threads: Optional[int] = None,
        backend: str = "embree",
        max_memory: Optional[str] = None,
        relight: Optional[Mapping[str, Any]] = None,
        **settings: Any,
    ) -> None: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def integrator(self) -> str: ...
    @property
    def settings_key(self) -> str:
        """Every setting that changes pixels, as one line."""
    def prepare(self, progress: Optional[Callback] = None) -> None:
        """Runs the technique's preparation now (the first render does it otherwise)."""
    def render(self, progress: Optional[Callback] = None, mid_pass: Optional[float] = None) -> Rendered:
        """Renders the job; `progress` returning False cancels it (the result is partial);
        Ctrl-C cancels it and raises KeyboardInterrupt."""
    def aovs(self, progress: Optional[Callback] = None) -> Dict[str, npt.NDArray[np.float32]]:
        """The auxiliary images by name: albedo, normal, position (H x W x 3), depth,
        object_id, material_id (H x W)."""
    def set_camera(
        self,
        *,
        position: Optional[Sequence[float]] = None,
        look_at: Optional[Sequence[float]] = None,
        up: Optional[Sequence[float]] = None,
        fov: Optional[float] = None,
    ) -> None:
        """Looks through another camera; the values not given stay."""
    def report(self) -> List[str]:
        """Statistics of the technique's preparation, one line each."""

def read_image(path: _Path) -> _Image:
    """Reads an image file as float32, height x width x 3."""

def write_image(
    path: _Path,
    image: _Image,
    *,
    exposure: float = 0.0,
    half: bool = False,
    color_space: str = "srgb",
) -> None:
    """Writes a float32 height x width x 3 array (linear sRGB) through the command line's
    outputs, the linear formats in `color_space`."""

def check_output(path: _Path) -> None:
    """Checks that an image can be written at `path`, as the command line does first."""

def integrators() -> List[str]:
    """The technique names `integrator` takes."""
