"""``render()`` for every environment: an RGB image or the SVG of the match now."""

from __future__ import annotations

from typing import Any, Optional, Sequence

#: Pixels per map unit of ``rgb_array`` frames.
RGB_SCALE = 8.0


class Renderer:
    """Checks the render mode once; renders a native environment in it."""

    def __init__(self, mode: Optional[str], modes: Sequence[str]) -> None:
        if mode is not None and mode not in modes:
            raise ValueError(f"render_mode {mode!r} is not one of {', '.join(modes)} (or None)")
        self.mode = mode

    def render(self, env: Any) -> Any:
        if self.mode == "rgb_array":
            return env.render_rgb(RGB_SCALE)
        if self.mode == "svg":
            return env.render_svg()
        return None
