"""``python -m cellgl.texture``: rewrite the shader files generated from the parameter table."""
from cellgl.texture.shader import write_generated

for path in write_generated():
    print(f"wrote {path}")
