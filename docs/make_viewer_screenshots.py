"""Make docs/screenshots/view-*.png with `cellgl view --screenshot` (needs a display or Xvfb).

    xvfb-run -a -s "-screen 0 1280x1024x24" python docs/make_viewer_screenshots.py
"""

import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHOTS = [
    ("view-2d.png", ["flagstone", "--mode", "2d"]),
    ("view-3d.png", ["flagstone", "--mode", "3d", "--shape", "sphere"]),
    ("view-tiled.png", ["flagstone", "--mode", "tiled", "--set", "tileable=true"]),
    ("view-anim.png", ["flagstone", "--mode", "anim", "--time", "0.75"]),
]

env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
for name, args in SHOTS:
    out = os.path.join(HERE, "screenshots", name)
    cmd = [sys.executable, "-m", "cellgl", "view", *args, "--size", "1024x640", "--frames", "3",
           "--screenshot", out]
    print(" ".join(cmd[2:]))
    subprocess.run(cmd, check=True, env=env, cwd=ROOT)
