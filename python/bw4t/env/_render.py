"""What every single-match environment shows of its match: ``render()`` (an RGB image or
the SVG of the match now), the digest, the statistics, the tick."""

from __future__ import annotations

from typing import Any, Dict, Optional, Sequence

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


class MatchViews:
    """For environments holding one native match as ``_env`` and a ``_renderer``."""

    _env: Any
    _renderer: Renderer

    def render(self) -> Any:
        """``rgb_array``: the match now as an RGB image (H × W × 3, uint8); ``svg``: as
        an SVG document (a string); no render mode: ``None``."""
        return self._renderer.render(self._env)

    def render_svg(self) -> str:
        """The match now as an SVG document, whatever the render mode."""
        return self._env.render_svg()

    def digest(self) -> int:
        """The match's digest: equal digests mean equal matches, bit for bit."""
        return self._env.digest()

    def stats(self) -> Dict[str, Any]:
        """The match's statistics (drops, messages, ticks, sequence index) and each robot's."""
        return self._env.stats()

    @property
    def tick(self) -> int:
        """Ticks simulated in this episode."""
        return self._env.tick()
