"""The GL layer: shader text (:mod:`cellgl.gl.glsl`: load ``shaders/``, resolve includes, map
driver errors back to files; pure text, no GL) and the headless context with its program cache
(:mod:`cellgl.gl.context`). Everything that runs on the GPU goes through here. What cellgl knows
of each context is one state object (:mod:`cellgl.gl.registry`); the only code that uses moderngl
beyond its public API is :mod:`cellgl.gl.moderngl_seam`."""
