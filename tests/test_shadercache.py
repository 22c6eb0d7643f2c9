"""The drivers' shader disk caches pointed at a writable cellgl folder (cellgl/gl/shadercache.py):
what it sets, what it leaves alone, and that a fresh process fills the cache."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cellgl.gl import shadercache

_VARS = ("MESA_SHADER_CACHE_DIR", "MESA_SHADER_CACHE_DISABLE", "__GL_SHADER_DISK_CACHE",
         "__GL_SHADER_DISK_CACHE_PATH", "__GL_SHADER_DISK_CACHE_SKIP_CLEANUP",
         shadercache.ENV_SWITCH, shadercache.ENV_DIR, "XDG_CACHE_HOME")


@pytest.fixture
def clean(monkeypatch):
    for name in _VARS:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(shadercache, "_prepared", {})
    return monkeypatch


def test_points_both_drivers_at_the_named_folder(clean, tmp_path):
    clean.setenv(shadercache.ENV_DIR, str(tmp_path / "c"))
    done = shadercache.prepare_environment()
    assert done["MESA_SHADER_CACHE_DIR"] == str(tmp_path / "c" / "mesa") == os.environ["MESA_SHADER_CACHE_DIR"]
    assert done["__GL_SHADER_DISK_CACHE_PATH"] == str(tmp_path / "c" / "nvidia")
    assert os.environ["__GL_SHADER_DISK_CACHE"] == "1"
    assert (tmp_path / "c" / "mesa").is_dir() and (tmp_path / "c" / "nvidia").is_dir()
    assert shadercache.prepare_environment() == done          # once per process


def test_default_folder_is_the_users_cache(clean, tmp_path):
    clean.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert shadercache.cache_dir() == tmp_path / "cellgl" / "shaders"


def test_leaves_what_the_user_set(clean, tmp_path):
    clean.setenv(shadercache.ENV_DIR, str(tmp_path))
    clean.setenv("MESA_SHADER_CACHE_DIR", "/somewhere/else")
    clean.setenv("__GL_SHADER_DISK_CACHE", "0")
    done = shadercache.prepare_environment()
    assert done == {}
    assert os.environ["MESA_SHADER_CACHE_DIR"] == "/somewhere/else"
    assert "__GL_SHADER_DISK_CACHE_PATH" not in os.environ


def test_switched_off_sets_nothing(clean, tmp_path):
    clean.setenv(shadercache.ENV_SWITCH, "0")
    clean.setenv(shadercache.ENV_DIR, str(tmp_path))
    assert shadercache.prepare_environment() == {}
    assert "MESA_SHADER_CACHE_DIR" not in os.environ


def test_an_unwritable_folder_sets_nothing(clean, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    clean.setenv(shadercache.ENV_DIR, str(blocker / "cache"))
    assert shadercache.cache_dir() is None
    assert shadercache.prepare_environment() == {}


_CHILD = """
from cellgl.gl import shadercache
shadercache.prepare_environment()
from cellgl.gl import context
ctx = context.get_context()
print(ctx.info.get("GL_RENDERER", ""))
ctx.program(vertex_shader="#version 330 core\\nin vec2 p; void main() { gl_Position = vec4(p * 0.5, 0.0, 1.0); }",
            fragment_shader="#version 330 core\\nout vec4 c; void main() { c = vec4(0.25, 0.5, 0.75, 1.0); }")
"""


def test_a_fresh_process_fills_the_cache(ctx, tmp_path):
    """A program compiled in a process with the cache prepared is on disk after it (Mesa's
    drivers; a driver without a disk cache: skipped)."""
    env = {k: v for k, v in os.environ.items() if k not in _VARS}
    env[shadercache.ENV_DIR] = str(tmp_path)
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1]) + os.pathsep + env.get("PYTHONPATH", "")
    p = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    files = [f for f in tmp_path.rglob("*") if f.is_file()]
    if not files and "llvmpipe" not in p.stdout and "Mesa" not in p.stdout:
        pytest.skip(f"{p.stdout.strip()}: no shader disk cache written")
    assert files, f"nothing cached under {tmp_path} ({p.stdout.strip()})"
