"""Files, the bottom layer: writers that know nothing of recipes or GL. :mod:`~cellgl.io.formats`
writes PNG, EXR, TIFF and NPY atomically and streamed, :mod:`~cellgl.io.tempfiles` the temporary
files, folders and locks under them, :mod:`~cellgl.io.containers` DDS and KTX2,
:mod:`~cellgl.io.blocks` BCn blocks, :mod:`~cellgl.io.colour` colour spaces,
:mod:`~cellgl.io.spec` what an output can hold (formats, sizes, channels, each channel's
encoding), :mod:`~cellgl.io.progress` the progress bar. Rendering recipes into them is
:mod:`cellgl.bake` (``cellgl bake``)."""
