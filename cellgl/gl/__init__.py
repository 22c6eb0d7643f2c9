"""The GL layer: shader text (:mod:`cellgl.gl.glsl`: load ``shaders/``, resolve includes, map
driver errors back to files; pure text, no GL) and the headless context with its program cache
(:mod:`cellgl.gl.context`). Everything that runs on the GPU goes through here."""
