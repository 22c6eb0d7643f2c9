"""The web playground (``cellgl playground``) in a real browser: Debian's headless Chromium driven
by selenium, the site opened from ``file://`` with the network off (WebGL2 on SwiftShader).

For every preset the page offers: its canvas equals ``cellgl bake`` at the same size within
1/255; after three sliders move it equals ``cellgl bake --set`` with the values the page
reports; the GLSL ES and three.js snippets it copies compile and render the same pixels; the
``cellgl bake`` command it copies runs and writes that image. One browser session serves all
presets (64 x 64 canvases). A missing Chromium skips unless CELLGL_REQUIRE_GPU is set (CI).
"""
from __future__ import annotations

import base64
import importlib.util
import os
import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pytest

from cellgl.recipes import is_pups, list_presets, load_recipe

ROOT = Path(__file__).resolve().parents[1]
SIZE = 64
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
REQUIRE = os.environ.get("CELLGL_REQUIRE_GPU", "").strip().lower() in ("1", "true", "yes")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--proxy-server=127.0.0.1:9",
         "--enable-unsafe-webgpu", "--use-webgpu-adapter=swiftshader",
         "--window-size=1400,900")


def _texture_presets():
    from cellgl.playground.variants import exportable

    out = []
    for name, _ in list_presets():
        r = load_recipe(name)
        if not is_pups(r) and exportable(r) is None:
            out.append(name)
    return out


PRESETS = _texture_presets()


def _export_helpers():
    spec = importlib.util.spec_from_file_location("_cellgl_test_export", ROOT / "tests" / "test_export.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    from cellgl.playground import build_site

    out = tmp_path_factory.mktemp("playground")
    res = build_site(out)
    assert res["presets"] == PRESETS
    return out


def start_chromium(profile: Path, *, browser_log: bool = False):
    """Headless Chromium under selenium (:data:`FLAGS`, a fresh ``profile`` folder, 240 s for a
    script; ``browser_log``: the page's console kept). Without chromium, chromedriver or selenium
    the test skips, or fails where CI requires them (``CELLGL_REQUIRE_GPU``). The caller quits it."""
    if CHROMIUM is None or DRIVER is None:
        if REQUIRE:
            pytest.fail("chromium and chromium-driver are required (CELLGL_REQUIRE_GPU=1); .ci/setup installs them")
        pytest.skip("no chromium / chromedriver (apt install chromium chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        if REQUIRE:
            pytest.fail("selenium is required (the test extra)")
        pytest.skip("no selenium")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for f in FLAGS:
        opts.add_argument(f)
    opts.add_argument(f"--user-data-dir={profile}")
    if browser_log:
        opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(options=opts, service=Service(DRIVER))
    driver.set_script_timeout(240)
    return driver


@pytest.fixture(scope="module")
def page(site, tmp_path_factory):
    driver = start_chromium(tmp_path_factory.mktemp("chromium-profile"), browser_log=True)
    try:
        driver.get((site / "index.html").as_uri() + f"?size={SIZE}")
        driver.execute_async_script("arguments[arguments.length - 1](window.cellglPlayground.idle())")
        yield driver
    finally:
        driver.quit()


def call(driver, js: str):
    """Run ``js`` (an expression, may be a promise) in the page and return its value."""
    return driver.execute_async_script(
        f"const done = arguments[arguments.length - 1];"
        f"Promise.resolve().then(() => {js}).then(done, (e) => done({{__error: String(e && e.stack || e)}}));")


def ok(value):
    assert not (isinstance(value, dict) and "__error" in value), value.get("__error")
    return value


def pixels(b64: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), np.uint8).reshape(SIZE, SIZE, 4)


def bake(tmp_path, name, sets=(), stem="bake") -> np.ndarray:
    from PIL import Image

    from cellgl.bake.core import bake as bake_file

    path = tmp_path / f"{stem}.png"
    bake_file(name, path, size=(SIZE, SIZE), sets=list(sets), progress=False)
    return np.asarray(Image.open(path).convert("RGBA"))


def assert_close(got: np.ndarray, want: np.ndarray, what: str):
    diff = np.abs(got[..., :3].astype(int) - want[..., :3].astype(int))
    assert diff.max() <= 1, f"{what}: {int((diff > 1).any(axis=-1).sum())} pixels differ by more than 1/255 " \
                            f"(max {diff.max()})"


def move_sliders(driver, name: str) -> list[str]:
    """Drag three of the preset's sliders (set the range input and fire its input event, as a
    drag does); returns the names moved."""
    v = load_recipe(name).values
    # (Blender's points have no seed: move them instead)
    picks = ["offset_y" if v["distribution"] == "blender" else "seed",
             "jitter" if v["density_map"] != "none" else "frequency"]
    if v["fractal"] != "none" and v["fractal"] != "min":
        picks.append("gain")
    elif v["density_map"] != "none":
        picks.append("level_hi")
    else:
        picks.append("c2")           # from 0 on F1 presets: n = 2, another shader variant
    for i, p in enumerate(picks):
        ok(call(driver, f"""(() => {{
            const el = document.getElementById("p-{p}");
            const lo = Number(el.min), hi = Number(el.max);
            el.value = String(lo + (hi - lo) * {0.31 + 0.17 * i});
            el.dispatchEvent(new Event("input", {{bubbles: true}}));
            return window.cellglPlayground.idle();
        }})()"""))
    return picks


THREE_STUB = """(() => {
    const text = window.cellglPlayground.copyText("threejs");
    const body = text.replace(/^import .*$/m, "").replace("export const", "const");
    const THREE = { GLSL3: "300 es", ShaderMaterial: class { constructor(o) { Object.assign(this, o); } } };
    const m = new Function("THREE", body + "\\nreturn cellglMaterial;")(THREE);
    // three.js's GLSL3 ShaderMaterial prefix (#version, precision); vUv from a full-screen triangle
    const frag = m.fragmentShader.replace("in vec2 vUv;", "");
    return { glslVersion: m.glslVersion, vertex: m.vertexShader, frag };
})()"""


@pytest.mark.slow
@pytest.mark.parametrize("name", PRESETS)
def test_preset_in_the_browser_equals_the_bake(page, tmp_path, name):
    from cellgl.export.snippets import texture_program
    from cellgl.playground.variants import variant_id, variant_key

    st = ok(call(page, f"window.cellglPlayground.select({name!r})"))
    assert st["error"] is None and st["missing"] is None, st
    want_key = variant_key(texture_program(load_recipe(name), uniforms=True).defines)
    assert st["key"] == want_key and st["variant"] == variant_id(want_key)
    assert st["command"] == f"cellgl bake {name} -o {name}.png --size {SIZE}x{SIZE}"
    assert_close(pixels(call(page, "window.cellglPlayground.pixels()")), bake(tmp_path, name), f"{name} canvas")

    moved = move_sliders(page, name)
    st = ok(call(page, "window.cellglPlayground.state()"))
    assert st["error"] is None and st["missing"] is None, st
    assert sorted(s.split("=")[0] for s in st["sets"]) == sorted(moved), st["sets"]
    want = bake(tmp_path, name, st["sets"], "moved")
    shown = pixels(call(page, "window.cellglPlayground.pixels()"))
    assert_close(shown, want, f"{name} after --set {' '.join(st['sets'])}")
    assert np.abs(shown.astype(int) - bake(tmp_path, name)).max() > 8, "the sliders changed nothing"

    # the copied GLSL ES snippet compiles and renders the same pixels
    gles = ok(call(page, "window.cellglPlayground.copyText('gles')"))
    assert not re.search(r"^uniform ", gles, re.M) and "cellgl_texture_filtered" in gles
    got = pixels(ok(call(page, f"window.cellglPlayground.renderSnippet({gles!r})")))
    assert_close(got, want, f"{name} copied GLSL ES")
    # ... and the three.js material's fragment shader too
    three = ok(call(page, THREE_STUB))
    assert three["glslVersion"] == "300 es" and "projectionMatrix" in three["vertex"]
    # three.js adds #version and precision; vUv as the full-screen quad interpolates it
    frag = ("#version 300 es\nprecision highp float;\nprecision highp int;\n"
            f"vec2 pg_vuv() {{ return (floor(gl_FragCoord.xy) + 0.5) / {SIZE}.0; }}\n#define vUv pg_vuv()\n"
            + three["frag"])
    got = pixels(ok(call(page, f"window.cellglPlayground.renderFragment({frag!r})")))
    assert_close(got, want, f"{name} copied three.js fragment shader")

    # the copied command runs and writes the same image
    from PIL import Image

    from cellgl.cli import main

    argv = shlex.split(st["command"])
    assert argv[:3] == ["cellgl", "bake", name]
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(argv[1:]) == 0
    finally:
        os.chdir(cwd)
    ran = np.asarray(Image.open(tmp_path / f"{name}.png").convert("RGBA"))
    np.testing.assert_array_equal(ran, want)


@pytest.mark.slow
@pytest.mark.parametrize("name", [p for p in ("f1", "crumple", "density") if p in PRESETS])
def test_copied_wgsl_hlsl_godot_snippets_compile(page, tmp_path, name):
    helpers = _export_helpers()
    ok(call(page, f"window.cellglPlayground.select({name!r})"))
    move_sliders(page, name)
    for target in ("wgsl", "hlsl", "godot"):
        text = ok(call(page, f"window.cellglPlayground.copyText({target!r})"))
        assert f"--target {target}" in text and " --set seed=" in text
        if target == "godot":   # the exporter's own fragment(), as compile_snippet expects it
            text += "\nvoid fragment()\n{\n    COLOR = cellgl_texture(UV);\n}\n"
        helpers.compile_snippet(tmp_path, target, text)


@pytest.mark.slow
def test_tiled_and_animated_views(page):
    ok(call(page, "window.cellglPlayground.select('f1')"))
    flat = call(page, "window.cellglPlayground.pixels()")
    page.find_element("css selector", "#views button[data-view=tiled]").click()
    st = ok(call(page, "window.cellglPlayground.idle()"))
    assert st["view"] == "tiled" and st["error"] is None
    tiled = pixels(call(page, "window.cellglPlayground.pixels()"))
    assert (tiled != pixels(flat)).any()
    # 3 x 3 copies: the texture repeats every SIZE / 3 pixels (a third of a pixel off per copy)
    k, t = SIZE // 3, tiled[..., :3].astype(int)
    same = np.abs(t[:k, :k] - t[k:2 * k, k:2 * k]).mean()
    other = np.abs(t[:k, :k] - t[:k, k // 2:k // 2 + k]).mean()
    assert same < other / 2, (same, other)
    page.find_element("css selector", "#views button[data-view=anim]").click()
    a = ok(call(page, "new Promise((r) => setTimeout(r, 300)).then(() => window.cellglPlayground.state())"))
    first = call(page, "window.cellglPlayground.pixels()")
    b = ok(call(page, "new Promise((r) => setTimeout(r, 900)).then(() => window.cellglPlayground.state())"))
    assert b["error"] is None and b["rendered"] > a["rendered"]
    assert call(page, "window.cellglPlayground.pixels()") != first
    assert any(s.startswith("offset_x=") for s in b["sets"]), b["sets"]   # the command follows the frame
    page.find_element("css selector", "#views button[data-view='2d']").click()
    ok(call(page, "window.cellglPlayground.idle()"))


@pytest.mark.slow
def test_page_works_offline_and_names_what_it_leaves_out(page, site):
    logs = [e for e in page.get_log("browser") if e["level"] == "SEVERE"]
    assert not logs, logs
    note = page.find_element("id", "refused").text
    pups = [n for n, _ in list_presets() if n.startswith("pups-")]
    if pups:
        assert f"the {len(pups)} PUPs presets" in note
    assert "stained-glass" in note or "stained-glass" in PRESETS
    # every file the page loads is in the site: nothing from the network
    html = (site / "index.html").read_text()
    assert "http://" not in html and "https://" not in html


@pytest.mark.slow
def test_screenshot(page, tmp_path):
    """The docs' screenshot (docs/screenshots/playground.png; CELLGL_UPDATE_DOCS=1 rewrites it)."""
    from PIL import Image

    page.set_window_size(1400, 900)
    url = page.current_url.split("?")[0]
    page.get(url + "?size=256&preset=flagstone")
    ok(call(page, "window.cellglPlayground.idle()"))
    ok(call(page, """(() => { const el = document.getElementById("p-frequency");
        el.value = "6"; el.dispatchEvent(new Event("input", {bubbles: true}));
        return window.cellglPlayground.idle(); })()"""))
    shot = tmp_path / "playground.png"
    page.save_screenshot(str(shot))
    img = Image.open(shot).convert("RGB")
    assert img.size[0] >= 1200
    # the canvas shows the texture (not the empty checkerboard)
    assert np.asarray(img).std() > 20
    doc = ROOT / "docs" / "screenshots" / "playground.png"
    if os.environ.get("CELLGL_UPDATE_DOCS") == "1":
        img.resize((img.size[0] * 3 // 4, img.size[1] * 3 // 4), Image.LANCZOS).quantize(128).save(doc, optimize=True)
    assert doc.is_file() and doc.stat().st_size < 400_000
    page.get(url + f"?size={SIZE}")        # as the other tests expect it
    ok(call(page, "window.cellglPlayground.idle()"))


@pytest.mark.slow
def test_page_warns_where_the_recipe_check_refuses(page):
    from cellgl.texture.schema import RecipeError

    ok(call(page, "window.cellglPlayground.select('f1')"))
    for name, value in (("max_points", 3), ("min_points", 5)):
        ok(call(page, f"""(() => {{ const el = document.getElementById("p-{name}");
            el.value = "{value}"; el.dispatchEvent(new Event("input", {{bubbles: true}}));
            return window.cellglPlayground.idle(); }})()"""))
    st = ok(call(page, "window.cellglPlayground.state()"))
    assert st["problems"] == ["min_points exceeds max_points"], st["problems"]
    assert page.find_element("id", "notice").is_displayed()
    with pytest.raises(RecipeError, match="min_points"):
        load_recipe("f1").set_from_strings(st["sets"])
    ok(call(page, "window.cellglPlayground.select('f1')"))
    assert ok(call(page, "window.cellglPlayground.state()"))["problems"] == []


def _wgsl_consts(text: str) -> tuple[str, dict]:
    """A WGSL snippet's code with its ``const cellgl_*`` values cut out, and those values."""
    values = {}

    def cut(m):
        body = m.group(3)
        while re.search(r"<[^<>]*>", body):
            body = re.sub(r"<[^<>]*>", "", body)
        body = re.sub(r"vec\d|array", "", body)
        values[m.group(1)] = [float(x) for x in re.findall(r"-?\d+(?:\.\d*)?(?:e[-+]?\d+)?", body)]
        return f"const cellgl_{m.group(1)}: {m.group(2)} = ...;"

    code = re.sub(r"^const cellgl_(\w+): ([^=]+) = (.*);$", cut, text.split("\n\n", 1)[1], flags=re.M)
    return code, values


@pytest.mark.slow
@pytest.mark.parametrize("name", [p for p in ("f1", "crumple", "wood-grain", "density", "qin-marble")
                                  if p in PRESETS])
def test_copied_wgsl_equals_the_exporter(page, name):
    """The page writes the current values into the WGSL snippet; with the values it reports,
    ``cellgl export --target wgsl --no-fold --set ...`` gives the same code and the same numbers (the
    octave mean, measured on the GPU in the page, to 1e-5; Poisson thresholds to 1 in 2^32)."""
    from cellgl.export import export

    ok(call(page, f"window.cellglPlayground.select({name!r})"))
    move_sliders(page, name)
    st = ok(call(page, "window.cellglPlayground.state()"))
    page_code, page_vals = _wgsl_consts(ok(call(page, "window.cellglPlayground.copyText('wgsl')")))
    py_code, py_vals = _wgsl_consts(export(load_recipe(name).set_from_strings(st["sets"]), "wgsl", fold=False))
    assert page_code == py_code
    assert page_vals.keys() == py_vals.keys()
    for k, want in py_vals.items():
        tol = 1e-5 if k == "octave_mean" else 1 if "thresholds" in k else 0
        np.testing.assert_allclose(page_vals[k], want, rtol=0, atol=tol, err_msg=k)


@pytest.mark.slow
@pytest.mark.parametrize("name", [p for p in ("f1", "flagstone", "wood-grain") if p in PRESETS])
def test_webgpu_renders_the_copied_wgsl_as_the_bake(page, tmp_path, name):
    """Where the browser offers WebGPU (headless Chromium here: SwiftShader's adapter), the
    WebGPU renderer draws the WGSL snippet the page copies; it gives the bake's pixels."""
    assert call(page, "window.cellglPlayground.webgpu()") is True
    ok(call(page, f"window.cellglPlayground.select({name!r})"))
    move_sliders(page, name)
    st = ok(call(page, "window.cellglPlayground.state()"))
    got = pixels(ok(call(page, "window.cellglPlayground.webgpuPixels()")))
    assert_close(got, bake(tmp_path, name, st["sets"]), f"{name} WebGPU")
    page.find_element("id", "use-webgpu").click()
    st = ok(call(page, "window.cellglPlayground.idle()"))
    assert st["error"] is None, st["error"]
    assert page.find_element("id", "gpuview").is_displayed()
    page.find_element("css selector", "#renderer button[data-r=webgl2]").click()
    ok(call(page, "window.cellglPlayground.idle()"))


def test_site_files_and_refusals(tmp_path):
    """Without a browser: the site a recipe file gives (its commands name the file), every
    preset's variant file present, and a clear error when no preset can be shown."""
    import json

    from cellgl.cli import main
    from cellgl.playground import build_site

    recipe = tmp_path / "my recipe.json"
    load_recipe("f2").replace(frequency=5.0).save(recipe)
    out = tmp_path / "site"
    res = build_site(out, [str(recipe), "hull"], thumbs=False, neighbours=False)
    assert res["presets"] == ["f2", "hull"] and res["variants"] == 2
    text = (out / "data" / "site.js").read_text()
    site = json.loads(text[text.index("(") + 1:text.rindex(")")])
    assert [p["source"] for p in site["presets"]] == [str(recipe), "hull"]
    assert site["presets"][0]["values"]["frequency"] == 5.0
    for p in site["presets"]:
        assert (out / "variants" / f"{p['variant']}.js").is_file()
    for f in ("index.html", "playground.js", "playground.css"):
        assert (out / f).stat().st_size > 1000
    with pytest.raises(ValueError, match="no preset to show: pups-cow: PUPs"):
        build_site(tmp_path / "none", ["pups-cow"])
    assert main(["playground", "-o", str(tmp_path / "none"), "--preset", "stained-glass", "-q"]) == 2


#: values the page's inactive() is held to cellgl.texture.params.inactive at (on every preset)
INACTIVE_CASES = ({}, {"metric": "minkowski"}, {"distribution": "jitter"}, {"distribution": "blender", "seed": 0},
                  {"density_map": "radial"}, {"density_map": "ramp_y", "distribution": "poisson"},
                  {"dimension": 4}, {"dimension": 3, "fractal": "min"}, {"c_smooth": 0.5, "smoothness": 0.1},
                  {"cell_mix": 0.3, "smoothness": 0.0}, {"warp_amount": 1.5, "noise_color": 0.2},
                  {"c_noise": 1.0, "orbit_radius": 0.2})


@pytest.mark.slow
def test_inactive_parameters_are_greyed_as_python_says(page):
    """The page greys out (and disables) the parameters that change nothing, with the reason
    as tooltip: the rules of cellgl.texture.params.ACTIVE_WHEN, the same words as in Python."""
    from cellgl.texture import params as P
    from cellgl.texture.params import inactive

    for name in PRESETS:
        values = load_recipe(name).values
        got = ok(call(page, f"(() => {{ window.cellglPlayground.select({name!r}); "
                            f"return {list(INACTIVE_CASES)!r}.map((c) => window.cellglPlayground.inactive(c)); }})()"
                      .replace("True", "true").replace("False", "false")))
        for case, page_says in zip(INACTIVE_CASES, got):
            python_says = {k: v for k, v in inactive({**values, **case}).items()
                           if P.PARAMS_BY_NAME[k].group != "material"}    # the page has no material group
            assert page_says == python_says, (name, case)
    ok(call(page, "window.cellglPlayground.select('f1')"))
    row = ok(call(page, """(() => { const r = document.getElementById("p-minkowski_p").closest(".param");
        return { cls: r.className, title: r.title, disabled: document.getElementById("p-minkowski_p").disabled }; })()"""))
    assert "inactive" in row["cls"] and row["disabled"], row
    assert row["title"].startswith("inactive: needs metric minkowski\n"), row["title"]
    ok(call(page, """(() => { const el = document.getElementById("p-metric");
        el.value = "minkowski"; el.dispatchEvent(new Event("input", {bubbles: true}));
        return window.cellglPlayground.idle(); })()"""))
    row = ok(call(page, """(() => { const r = document.getElementById("p-minkowski_p").closest(".param");
        return { cls: r.className, title: r.title, disabled: document.getElementById("p-minkowski_p").disabled }; })()"""))
    assert "inactive" not in row["cls"] and not row["disabled"] and not row["title"].startswith("inactive"), row
    ok(call(page, "window.cellglPlayground.select('f1')"))


def test_preset_arguments(tmp_path, monkeypatch, capsys):
    """``--preset f1 --preset f1`` does the work once; an unknown ``--preset`` lists what the
    page accepts (no pups-*, which it refuses); two recipes with one name are refused."""
    from cellgl.cli import main
    from cellgl.playground import build_site, site as site_mod

    made = []
    real = site_mod._preset_entry
    monkeypatch.setattr(site_mod, "_preset_entry", lambda r, *a, **k: made.append(r.name) or real(r, *a, **k))
    res = build_site(tmp_path / "one", ["f1", "f1"], thumbs=False, neighbours=False)
    assert res["presets"] == ["f1"] and made == ["f1"]
    assert main(["playground", "-o", str(tmp_path / "x"), "--preset", "nope", "-q"]) == 2
    err = capsys.readouterr().err
    assert "--preset 'nope': unknown preset" in err and "pups-" not in err
    assert "flagstone" in err and "stained-glass" not in err       # refused by the exporter
    other = tmp_path / "other.json"
    load_recipe("f2").replace(name="f1").save(other)
    with pytest.raises(ValueError, match="named 'f1'"):
        build_site(tmp_path / "two", ["f1", str(other)], thumbs=False, neighbours=False)


def test_worker_processes_write_the_same_site(tmp_path):
    """The variants exported in worker processes (``--jobs``) are the files one process writes."""
    import gc

    from cellgl.playground import build_site

    sites = {}
    try:
        for jobs in (1, 2):
            for collector in (True, False):     # off while the exports run, then as it was
                (gc.enable if collector else gc.disable)()
                out = tmp_path / f"j{jobs}{collector}"
                res = build_site(out, ["f1", "hull"], thumbs=False, neighbours=False, jobs=jobs)
                assert gc.isenabled() is collector
                assert res["variants"] == 2
                sites[jobs, collector] = {p.relative_to(out): p.read_bytes() for p in sorted(out.rglob("*"))
                                          if p.is_file()}
    finally:
        gc.enable()
    assert all(files == sites[1, True] for files in sites.values())


def test_one_compile_gives_the_live_and_the_copied_texts(tmp_path):
    """A variant's live GLSL ES (with the mean probe) and its copied GLSL ES, Godot and HLSL come
    from one compile: the copied code is the live code without what only the probe reaches, and
    it compiles."""
    from cellgl.export import export
    from cellgl.playground.variants import _body, variant_texts

    helpers = _export_helpers()
    v = variant_texts("f1")
    assert "cellgl_playground_probe" in v["live"] and "cellgl_playground_probe" not in v["gles"]
    # printed from the compiled tree: what the exporter prints from its text
    assert v["wgsl"] == _body(export("f1", "wgsl", fold=False))
    live_lines = set(v["live"].split("\n"))
    assert all(ln in live_lines for ln in v["gles"].split("\n") if ln.strip())
    helpers.compile_snippet(tmp_path, "gles", v["gles"])
    helpers.compile_snippet(tmp_path, "hlsl", v["hlsl"])
