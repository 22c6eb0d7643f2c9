"""Files: :mod:`~cellgl.io.formats` writes PNG, EXR, TIFF and NPY atomically and streamed (no GL,
no recipes: the bottom layer), :mod:`~cellgl.io.bake` renders recipes to them tile by tile
(``cellgl bake``)."""
