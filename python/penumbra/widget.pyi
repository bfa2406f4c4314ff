from typing import Any

import ipywidgets  # type: ignore[import]
import traitlets

from . import Renderer

class Widget(ipywidgets.DOMWidget, metaclass=traitlets.MetaHasTraits):  # type: ignore[misc]
    renderer: Renderer
    max_samples: int
    frames_sent: int
    frames_cancelled: int
    height: traitlets.Int  # the cell's height in pixels (a synced trait)
    def __init__(self, renderer: Renderer, height: int = ..., max_samples: int = ...) -> None: ...
    def close(self) -> None: ...
