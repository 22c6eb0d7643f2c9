"""``cellgl blender-extension -o cellgl.zip``: the Blender extension (Blender 4.2+ format).

The zip holds ``blender_manifest.toml``, the add-on's ``__init__.py`` (it registers
:mod:`cellgl.blender.addon`, which comes in the cellgl wheel) and ``wheels/``: cellgl itself
(built from this source tree), ``moderngl`` and ``glcontext`` for each platform, and
``platformdirs`` (pure Python: where the known-answer check's records go). Blender ships
NumPy; the bake path imports neither Pillow nor SciPy (cellgl's other dependencies, used by PUPs
and image-driven recipes, which have no OSL export and are not in the Add menu), so they are not
bundled (tests/test_blender_addon.py checks the bake's imports).

Wheels are fetched by ``pip download --only-binary=:all: --platform TAG --python-version 3.11``
(:func:`pip_fetch`); ``build_extension(fetch=...)`` takes any other fetcher (the tests use one
that needs no network) and ``cache`` keeps what was fetched for the next build. The zip is
deterministic (sorted entries, fixed times) and written to a temporary name, then renamed.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

__all__ = ["PLATFORMS", "REQUIREMENTS", "build_extension", "manifest_text", "pip_fetch", "cellgl_wheel",
           "validate"]

#: Blender's platform names -> pip's platform tags (pip also takes older tags of each)
PLATFORMS = {
    "linux-x64": ("manylinux_2_28_x86_64", "manylinux2014_x86_64"),
    "windows-x64": ("win_amd64",),
    "macos-arm64": ("macosx_11_0_arm64",),
    "macos-x64": ("macosx_10_13_x86_64",),
}
#: the wheels cellgl's bake needs beside itself and Blender's NumPy
REQUIREMENTS = ("moderngl>=5.10", "glcontext>=3.0", "platformdirs>=3")
PYTHON_VERSION = "3.11"             # Blender 4.2 - 4.5 (and 5.0's 3.11 builds)
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)

#: the extension's own module: Blender imports it as bl_ext.<repository>.cellgl
INIT_PY = '''"""cellgl for Blender: every cellgl preset as a shader node, baked on the GPU.

The add-on lives in the bundled cellgl wheel (cellgl.blender.addon); this module hands over.
"""


def register():
    from cellgl.blender import addon

    addon.register()


def unregister():
    from cellgl.blender import addon

    addon.unregister()
'''


def _version() -> str:
    from cellgl._version import __version__

    return __version__


def manifest_text(wheels, platforms) -> str:
    """``blender_manifest.toml`` for the wheel paths ``wheels`` (relative to the zip's root)."""
    lines = [
        'schema_version = "1.0.0"',
        'id = "cellgl"',
        f'version = "{_version()}"',
        'name = "cellgl"',
        'tagline = "Cellular textures as shader nodes, baked on the GPU"',
        'maintainer = "cellgl developers"',
        'type = "add-on"',
        'tags = ["Material", "Node"]',
        'blender_version_min = "4.2.0"',
        'license = ["SPDX:MIT"]',
        "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]",
        "wheels = [",
        *[f'  "./{w}",' for w in wheels],
        "]",
        "",
        "[permissions]",
        'clipboard = "Copy Snippet and Copy Bake Command put text on the clipboard"',
        'files = "Runs its GPU bake in a child process reading its own wheels"',
        "",
    ]
    # tagline: Blender's limit is 64 characters
    return "\n".join(lines)


def _source_root() -> Path:
    root = Path(__file__).resolve().parents[2]          # cellgl/blender/extension.py
    if not (root / "pyproject.toml").is_file():
        raise ValueError(f"cellgl blender-extension builds the cellgl wheel from its source tree; "
                         f"{root} has no pyproject.toml (install cellgl from a checkout: pip install -e .)")
    return root


def _offline_setuptools() -> bool:
    """The installed setuptools builds cellgl (>= 77, its license field): no build isolation,
    no network."""
    try:
        from importlib.metadata import version

        return int(version("setuptools").split(".")[0]) >= 77
    except (ImportError, ValueError, LookupError):
        return False


def cellgl_wheel(dest: Path) -> Path:
    """Build cellgl's own wheel from (a copy of) the source tree into ``dest``."""
    env = dict(os.environ, SOURCE_DATE_EPOCH="315532800")
    with tempfile.TemporaryDirectory(prefix="cellgl-wheel-") as tmp:
        src = Path(tmp) / "src"
        # a copy: an in-tree build writes build/ and *.egg-info into the checkout
        shutil.copytree(_source_root(), src, ignore=shutil.ignore_patterns(
            ".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".pytest_cache", "out", "docs",
            "tests", "benchmarks", "*.zip", "*.blend"))
        iso = ["--no-build-isolation"] if _offline_setuptools() else []
        proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", *iso, "--quiet", "-w",
                               tmp, str(src)], capture_output=True, text=True, env=env)
        if proc.returncode:
            raise RuntimeError(f"building the cellgl wheel failed: {proc.stderr.strip()[-2000:]}")
        built = sorted(Path(tmp).glob("cellgl-*.whl"))
        if not built:
            raise RuntimeError("building the cellgl wheel gave no cellgl-*.whl")
        dest.mkdir(parents=True, exist_ok=True)
        out = dest / built[0].name
        shutil.copyfile(built[0], out)
    return out


def pip_fetch(platform: str, tags, requirements, dest: Path) -> list[Path]:
    """Download the binary wheels of ``requirements`` for one Blender ``platform`` into ``dest``."""
    dest.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--only-binary=:all:", "--no-deps", "--quiet",
           "--python-version", PYTHON_VERSION, "--implementation", "cp", "-d", str(dest)]
    for t in tags:
        cmd += ["--platform", t]
    proc = subprocess.run(cmd + list(requirements), capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"pip download for {platform} failed: {proc.stderr.strip()[-2000:]}")
    return sorted(dest.glob("*.whl"))


def _check_wheels(platform: str, wheels) -> None:
    names = {Path(w).name.split("-")[0].lower().replace("_", "-") for w in wheels}
    missing = [r for r in REQUIREMENTS if r.split(">")[0].split("=")[0].lower() not in names]
    if missing:
        raise RuntimeError(f"no wheel for {', '.join(missing)} on {platform}")


def build_extension(output, *, platforms=tuple(PLATFORMS), fetch=pip_fetch, cache=None) -> Path:
    """Write the extension zip ``output``; returns its path.

    Parameters
    ----------
    platforms : Blender platform names (keys of :data:`PLATFORMS`).
    fetch : ``fetch(platform, pip_tags, requirements, dest) -> [wheel paths]``.
    cache : folder keeping the fetched wheels per platform; a second build fetches nothing.
    """
    from cellgl.io.formats import atomic_path

    output = Path(os.path.abspath(os.fspath(output)))
    if output.suffix != ".zip":
        raise ValueError(f"output {str(output)!r} must end in .zip")
    from cellgl.io.tempfiles import check_output

    check_output(output)        # before the build: a missing or read-only folder, a long name
    platforms = list(platforms)
    bad = [p for p in platforms if p not in PLATFORMS]
    if bad or not platforms:
        raise ValueError(f"platform {bad[0] if bad else '(none)'!r} is unknown; accepted: {', '.join(PLATFORMS)}")
    with tempfile.TemporaryDirectory(prefix="cellgl-ext-") as tmp:
        tmp = Path(tmp)
        files: dict[str, Path] = {}
        own = cellgl_wheel(tmp / "own")
        files[f"wheels/{own.name}"] = own
        for plat in platforms:
            where = Path(cache) / plat if cache else tmp / plat
            got = sorted(where.glob("*.whl")) if where.is_dir() else []
            try:
                _check_wheels(plat, got)
            except RuntimeError:
                got = fetch(plat, PLATFORMS[plat], REQUIREMENTS, where)
            _check_wheels(plat, got)
            for w in got:
                files[f"wheels/{Path(w).name}"] = Path(w)
        wheels = sorted(files)
        with atomic_path(output) as part, zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
            def add(name, data: bytes):
                info = zipfile.ZipInfo(name, _ZIP_TIME)
                info.external_attr = 0o644 << 16
                info.compress_type = zipfile.ZIP_DEFLATED
                z.writestr(info, data)

            add("__init__.py", INIT_PY.encode())
            add("blender_manifest.toml", manifest_text(wheels, platforms).encode())
            for name in wheels:
                add(name, files[name].read_bytes())
    return output


def validate(path) -> str:
    """Run Blender's own extension validator (``blender_ext.py validate``, shipped with the
    ``bpy`` module under scripts/addons_core/bl_pkg/cli) on ``path``; returns its output.

    Raises
    ------
    RuntimeError
        The validator reports a problem, or it is not installed (no ``bpy``).
    """
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("Blender's validator comes with the bpy module (pip install 'cellgl[blender]')")
    root = Path(list(spec.submodule_search_locations)[0])
    tools = sorted(root.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not tools:
        raise RuntimeError(f"blender_ext.py not found under {root}")
    proc = subprocess.run([sys.executable, str(tools[-1]), "validate", str(path)], capture_output=True,
                          text=True)
    out = (proc.stdout + proc.stderr).strip()
    if proc.returncode:
        raise RuntimeError(f"Blender's extension validator rejected {path}: {out}")
    return out
