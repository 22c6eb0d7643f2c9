"""``python -m cellgl.texture``: rewrite the files generated from the parameter table (the shader
files) and from the presets (the table of their octave means, cellgl.texture.means)."""
from cellgl.texture.means import write_table
from cellgl.texture.reference import measure_mean
from cellgl.texture.shader import write_generated

for path in write_generated():
    print(f"wrote {path}")
print(f"wrote {write_table(measure_mean)}")
