"""The web playground (``cellgl playground -o DIR``): a static site to try every texture preset in
the browser; :mod:`~cellgl.playground.site` writes it, :mod:`~cellgl.playground.variants` exports
its shader variants. See docs/playground.md."""
from __future__ import annotations

from cellgl.playground.site import build_site

__all__ = ["build_site"]
