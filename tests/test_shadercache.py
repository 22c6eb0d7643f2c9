"""cellgl's cache folder and the drivers' shader disk caches (cellgl/gl/shadercache.py): nothing
set by default, the opt-in pointing both drivers into cellgl's folder, the OS's folder from
platformdirs, unusable places (a file, a dangling link, a missing home, a full disk) skipped with
a note, and that a fresh process fills the cache."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import platformdirs
import pytest

from cellgl.gl import shadercache

DRIVERS = "CELLGL_DRIVER_SHADER_CACHE"        # the opt-in
_VARS = ("MESA_SHADER_CACHE_DIR", "MESA_SHADER_CACHE_DISABLE", "__GL_SHADER_DISK_CACHE",
         "__GL_SHADER_DISK_CACHE_PATH", "__GL_SHADER_DISK_CACHE_SKIP_CLEANUP",
         shadercache.ENV_SWITCH, shadercache.ENV_DIR, DRIVERS, "XDG_CACHE_HOME")
_REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def clean(monkeypatch, tmp_path):
    """No cache variable set, nothing prepared or noted yet; plenty of free space (a test's own
    number replaces it); the temporary directory and the home folder the test's own."""
    for name in _VARS:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(shadercache, "_prepared", {})
    monkeypatch.setattr(shadercache, "_notes", [], raising=False)
    monkeypatch.setattr(shadercache, "_free", lambda place: 1 << 40, raising=False)
    (tmp_path / "tmp").mkdir()
    (tmp_path / "home").mkdir()
    monkeypatch.setattr(shadercache.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    return monkeypatch


def _driver_vars() -> dict:
    return {k: os.environ[k] for k in _VARS[:5] if k in os.environ}


def test_nothing_is_set_by_default(clean, tmp_path):
    """The drivers' own caches already compile once per driver (docs/performance.md): cellgl
    changes no variable of the process unless asked; NVIDIA's cache is never kept from trimming."""
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "c"))
    assert shadercache.prepare_environment() == {}
    assert _driver_vars() == {}
    assert shadercache.cache_dir() == tmp_path / "c"          # the records still go there


def test_opt_in_points_both_drivers_at_the_folder(clean, tmp_path):
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "c"))
    clean.setenv(DRIVERS, "1")
    done = shadercache.prepare_environment()
    assert done["MESA_SHADER_CACHE_DIR"] == str(tmp_path / "c" / "mesa") == os.environ["MESA_SHADER_CACHE_DIR"]
    assert done["__GL_SHADER_DISK_CACHE_PATH"] == str(tmp_path / "c" / "nvidia")
    assert os.environ["__GL_SHADER_DISK_CACHE"] == "1"
    assert "__GL_SHADER_DISK_CACHE_SKIP_CLEANUP" not in os.environ
    assert (tmp_path / "c" / "mesa").is_dir() and (tmp_path / "c" / "nvidia").is_dir()
    assert shadercache.prepare_environment() == done          # once per process


def test_the_folder_is_the_oss_own_from_platformdirs(clean, tmp_path):
    clean.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert shadercache.cache_dir() == tmp_path / "cellgl" / "shaders"
    # another OS's folder (macOS: ~/Library/Caches/cellgl), as platformdirs gives it
    caches = tmp_path / "home" / "Library" / "Caches"
    caches.parent.mkdir()
    clean.setattr(platformdirs, "user_cache_dir",
                  lambda appname=None, appauthor=None: str(caches / appname if appname else caches))
    assert shadercache.cache_dir() == caches / "cellgl" / "shaders"


def test_a_missing_home_is_never_made(clean, tmp_path):
    """HOME=/nonexistent (Debian's nobody): no home folder made; the user's folder in the
    temporary directory instead, with a note."""
    home = tmp_path / "nonexistent" / "dir"
    clean.setenv("HOME", str(home))
    got = shadercache.cache_dir()
    assert not (tmp_path / "nonexistent").exists()
    assert got is not None and got.is_relative_to(tmp_path / "tmp")
    assert (got.parent.stat().st_mode & 0o777) == 0o700
    assert any("does not exist" in n for n in shadercache.notes())
    shadercache.prepare_environment()
    assert not (tmp_path / "nonexistent").exists()


def test_a_named_folder_whose_parent_is_missing_is_not_made(clean, tmp_path):
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "a" / "b"))
    assert shadercache.cache_dir() is None
    assert not (tmp_path / "a").exists()


def test_a_shared_temporary_folder_of_another_is_not_used(clean, tmp_path):
    """The fallback in the shared temporary directory: a link planted there is refused."""
    clean.setenv("HOME", str(tmp_path / "missing" / "home"))
    user = os.getuid() if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "tmp" / f"cellgl-{user}").symlink_to(tmp_path / "elsewhere")
    assert shadercache.cache_dir() is None
    assert not list((tmp_path / "elsewhere").iterdir())


@pytest.mark.parametrize("blocker", ["file", "dangling link"])
@pytest.mark.parametrize("name", ["mesa", "nvidia"])
def test_an_unusable_driver_folder_is_skipped_with_a_note(clean, tmp_path, blocker, name):
    """A file or a dangling link where a driver's folder goes: that driver keeps its default,
    with a note, and no error (it was blamed on the driver: "could not create a context")."""
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "c"))
    clean.setenv(DRIVERS, "1")
    (tmp_path / "c").mkdir()
    if blocker == "file":
        (tmp_path / "c" / name).write_text("not a folder")
    else:
        (tmp_path / "c" / name).symlink_to(tmp_path / "gone")
    done = shadercache.prepare_environment()
    var = "MESA_SHADER_CACHE_DIR" if name == "mesa" else "__GL_SHADER_DISK_CACHE_PATH"
    other = "__GL_SHADER_DISK_CACHE_PATH" if name == "mesa" else "MESA_SHADER_CACHE_DIR"
    assert var not in os.environ and other in done
    assert any(str(tmp_path / "c" / name) in n and "skipped" in n for n in shadercache.notes())


def test_a_full_disk_switches_mesas_cache_off(clean, tmp_path):
    """Mesa maps its cache index: on a full disk it ends the process with SIGBUS. Too little free
    space where Mesa's cache goes (its default here) switches it off, with a note."""
    clean.setenv("XDG_CACHE_HOME", str(tmp_path))
    clean.setattr(shadercache, "_free", lambda place: 1 << 20)
    done = shadercache.prepare_environment()
    assert done == {"MESA_SHADER_CACHE_DISABLE": "true"} and _driver_vars() == done
    assert any("SIGBUS" in n and "1 MiB free" in n for n in shadercache.notes())


def test_a_full_disk_is_not_where_the_drivers_are_pointed(clean, tmp_path):
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "c"))
    clean.setenv(DRIVERS, "1")
    clean.setenv("MESA_SHADER_CACHE_DISABLE", "true")         # the user's: left alone
    clean.setattr(shadercache, "_free", lambda place: 0)
    assert shadercache.prepare_environment() == {}
    assert any("0 MiB free" in n for n in shadercache.notes())


def test_leaves_what_the_user_set(clean, tmp_path):
    clean.setenv(shadercache.ENV_DIR, str(tmp_path))
    clean.setenv(DRIVERS, "1")
    clean.setenv("MESA_SHADER_CACHE_DIR", "/somewhere/else")
    clean.setenv("__GL_SHADER_DISK_CACHE", "0")
    assert shadercache.prepare_environment() == {}
    assert os.environ["MESA_SHADER_CACHE_DIR"] == "/somewhere/else"
    assert "__GL_SHADER_DISK_CACHE_PATH" not in os.environ


def test_switched_off_keeps_no_folder(clean, tmp_path):
    clean.setenv(shadercache.ENV_SWITCH, "0")
    clean.setenv(DRIVERS, "1")
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "c"))
    assert shadercache.cache_dir() is None
    assert shadercache.prepare_environment() == {}
    assert not (tmp_path / "c").exists() and _driver_vars() == {}


@pytest.mark.parametrize("name", [shadercache.ENV_SWITCH, DRIVERS])
def test_a_bad_switch_is_refused_in_one_line(clean, name):
    clean.setenv(name, "yes")
    with pytest.raises(ValueError, match=rf"^{name}='yes' is not a switch; accepted values: 0, 1$"):
        shadercache.prepare_environment()


def test_an_unwritable_folder_sets_nothing(clean, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    clean.setenv(shadercache.ENV_DIR, str(blocker / "cache"))
    clean.setenv(DRIVERS, "1")
    assert shadercache.cache_dir() is None
    assert shadercache.prepare_environment() == {}
    assert any("no usable cellgl cache folder" in n for n in shadercache.notes())


_FULL = r"""
set -e
mount -t tmpfs -o size=1m tmpfs "$1"
dd if=/dev/zero of="$1/fill" bs=64k 2>/dev/null || true
shift
exec "$@"
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or shutil.which("unshare") is None,
                    reason="needs Linux and unshare")
def test_a_cache_on_a_full_disk_is_one_note_not_sigbus(ctx, tmp_path):
    """The real thing: XDG_CACHE_HOME on a full tmpfs (a private mount namespace), `cellgl
    info` and a bake: Mesa ended both with SIGBUS (exit 135); now info works and says why Mesa's
    cache is off, and the bake reports the full disk in one line."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    probe = subprocess.run(["unshare", "-rm", "true"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip("no user namespaces here (unshare -rm)")
    env = {k: v for k, v in os.environ.items() if k not in _VARS}
    env.update(XDG_CACHE_HOME=str(mnt), PYTHONPATH=str(_REPO))
    env.pop("CELLGL_SELFCHECK", None)
    cmd = ["unshare", "-rm", "sh", "-c", _FULL, "sh", str(mnt), sys.executable, "-m", "cellgl"]
    p = subprocess.run(cmd + ["info"], env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, (p.returncode, p.stderr[-1500:])
    line = next(x for x in p.stdout.splitlines() if x.startswith("shader_cache:"))
    assert "MESA_SHADER_CACHE_DISABLE=true" in line and "SIGBUS" in line, line
    p = subprocess.run(cmd + ["bake", "flagstone", "--size", "64", "-o", str(mnt / "x.png")],
                       env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and "No space left on device" in p.stderr, (p.returncode, p.stderr)


_CHILD = """
from cellgl.gl import shadercache
shadercache.prepare_environment()
from cellgl.gl import context
ctx = context.get_context()
print(ctx.info.get("GL_RENDERER", ""))
ctx.program(vertex_shader="#version 330 core\\nin vec2 p; void main() { gl_Position = vec4(p * 0.5, 0.0, 1.0); }",
            fragment_shader="#version 330 core\\nout vec4 c; void main() { c = vec4(0.25, 0.5, 0.75, 1.0); }")
"""


@pytest.mark.parametrize("how", ["the drivers' default", "opted in"])
def test_a_fresh_process_fills_the_cache(ctx, tmp_path, how):
    """A program compiled in a fresh process is on disk after it: in the driver's own default
    folder (nothing set), or in cellgl's with the opt-in (Mesa's drivers; a driver without a
    disk cache: skipped)."""
    env = {k: v for k, v in os.environ.items() if k not in _VARS}
    env["PYTHONPATH"] = str(_REPO) + os.pathsep + env.get("PYTHONPATH", "")
    if how == "opted in":
        env[shadercache.ENV_DIR] = str(tmp_path)
        env[DRIVERS] = "1"
    else:
        env["XDG_CACHE_HOME"] = str(tmp_path)
    p = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    files = [f for f in tmp_path.rglob("*") if f.is_file()]
    if not files and "llvmpipe" not in p.stdout and "Mesa" not in p.stdout:
        pytest.skip(f"{p.stdout.strip()}: no shader disk cache written")
    assert files, f"nothing cached under {tmp_path} ({p.stdout.strip()})"
    where = tmp_path / ("mesa" if how == "opted in" else "mesa_shader_cache")
    if "llvmpipe" in p.stdout or "Mesa" in p.stdout:
        assert any(f.is_relative_to(where) for f in files), files
