"""three.js renders the glTF material set (issue 45, item 3): GLTFLoader in headless Chromium (as
tests/test_playground.py drives it, selenium, SwiftShader WebGL) lights the quad of ``cellgl bake
--material gltf`` and the screenshot matches a reference render of the same maps: a
MeshStandardMaterial built by hand from the PNGs (colour sRGB, ORM linear as roughness, metalness
and occlusion, the normal map) on three.js's own plane, which shares none of the .gltf's geometry,
uvs, tangents or wiring. three.js is the npm package ``three`` that .ci/setup installs into
``.venv/three``; without it, or without Chromium, the test skips (slow tier)."""
from __future__ import annotations

import base64
import functools
import http.server
import io
import os
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest

from cellgl.bake import material_sets as M

ROOT = Path(__file__).resolve().parents[1]
THREE = ROOT / ".venv" / "three" / "node_modules" / "three"
SIZE = 64
#: the tolerance of the screenshot against the reference, in 8-bit sRGB steps (mean and 99th
#: percentile of |difference| over the pixels and channels): on SwiftShader both are 0 (three.js
#: r170); a GPU may round the .gltf's vertex tangents and the reference plane's derived ones apart
MEAN_TOL, P99_TOL = 1.0, 6


def _png(url: str) -> np.ndarray:
    from PIL import Image

    assert url.startswith("data:image/png;base64,"), url[:40]
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB")).astype(int)


@pytest.fixture
def browser(tmp_path):
    from test_playground import start_chromium

    if not (THREE / "build" / "three.module.js").is_file():
        pytest.skip("three.js (npm three, .venv/three) is not installed")
    driver = start_chromium(tmp_path / "chromium-profile")
    try:
        yield driver
    finally:
        driver.quit()


@pytest.mark.slow
def test_threejs_renders_the_gltf_set_as_the_same_maps_by_hand(ctx, tmp_path, browser):
    site = tmp_path / "site"
    site.mkdir()
    M.bake_material("flagstone", site / "set", "gltf", size=SIZE, progress=False)
    shutil.copy(Path(__file__).with_name("threejs_material.html"), site / "index.html")
    os.symlink(THREE, site / "three")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(site))
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        browser.get(f"http://127.0.0.1:{server.server_address[1]}/index.html?size={SIZE}&stem=flagstone")
        res = browser.execute_async_script("const done = arguments[arguments.length - 1];"
                                           "window.cellglResult.then(done);")
    finally:
        server.shutdown()
        server.server_close()
    assert res and "error" not in res, res
    # GLTFLoader connected every map: colour as sRGB, one ORM image as roughness, metalness and occlusion
    assert res["wiring"] == {"type": "MeshStandardMaterial", "map": "srgb", "normalMap": True, "roughnessMap": True,
                             "metalnessMap": True, "aoMap": True, "sameOrm": True, "tangents": True}
    got, ref, flat = (_png(res[k]) for k in ("fromGltf", "reference", "noNormalMap"))
    assert got.shape == ref.shape == (SIZE, SIZE, 3)
    from PIL import Image

    Image.fromarray(np.hstack([got, ref, flat]).astype(np.uint8)).save(tmp_path / "threejs.png")
    diff = np.abs(got - ref)
    mean, p99 = diff.mean(), np.percentile(diff, 99)
    assert mean <= MEAN_TOL and p99 <= P99_TOL, (mean, p99, diff.max())
    # the check can fail: the lit quad is the texture (not a blank canvas), and its normal map shows
    base = np.asarray(Image.open(site / "set" / "flagstone_baseColor.png").convert("RGB")).astype(float)
    assert np.corrcoef(got.mean(-1).ravel(), base.mean(-1).ravel())[0, 1] > 0.5
    assert np.abs(got - flat).mean() > 4 * max(mean, 0.5)
    # and the normal map lights the slopes as the height says (OpenGL convention, glTF's): the
    # light comes from the upper left, so the normal map brightens where height rises to the right
    # and down the image (measured correlation 0.40; the map's green flipped, DirectX, gives -0.07)
    from cellgl.bake.core import bake

    bake("flagstone", tmp_path / "height.png", size=SIZE, channels=["height"], bit_depth=16, progress=False)
    rows, cols = np.gradient(np.asarray(Image.open(tmp_path / "height.png")).astype(float))
    assert np.corrcoef((got - flat).mean(-1).ravel(), (rows + cols).ravel())[0, 1] > 0.25
