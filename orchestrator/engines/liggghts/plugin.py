"""Build and cache what the project compiles for LIGGGHTS (custom_contact/), outside the clone:

- the bilinear contact plugin, loaded into Debian's `liggghts` (clumps and spheres);
- a LIGGGHTS executable built from Debian's own source of the installed version with superquadric
  particles and the bilinear law compiled in (superquadric bricks: Debian's build has none).

Cache: ${DEMORCH_CACHE:-${XDG_CACHE_HOME:-~/.cache}/dem-orchestrator}/contact/<key>/ and
…/liggghts-superquadric/<key>/, key = sha256 of the sources, the build script and the installed
liggghts package version. A build happens in a temporary directory renamed into place, so a
crashed build never leaves a half-made cache entry.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Callable

SOURCE_DIR = Path(__file__).resolve().parents[3] / "custom_contact"
SOURCES = ("normal_model_bilinear.h", "plugin.cpp", "build.sh")
LIBRARY = "libdemorch_bilinear.so"
SUPERQUADRIC_SOURCES = ("normal_model_bilinear.h", "build_liggghts.sh", "roundedbox_geometry.h", "roundedbox_candidates.h",
                        "roundedbox_law.h",
                        "pair_roundedbox.h", "pair_roundedbox.cpp", "fix_wall_roundedbox.h", "fix_wall_roundedbox.cpp",
                        "fix_roundedbox_history.h", "fix_roundedbox_history.cpp")
SUPERQUADRIC_EXECUTABLE = "liggghts"


from orchestrator.engines.base import ContactBuildError


def cache_root() -> Path:
    if "DEMORCH_CACHE" in os.environ:
        return Path(os.environ["DEMORCH_CACHE"])
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "dem-orchestrator"


def engine_version() -> str:
    try:
        result = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "liggghts"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    return result.stdout.strip() or "unknown"


def source_hash(sources: tuple[str, ...] = SOURCES) -> str:
    digest = hashlib.sha256()
    for name in sources:
        digest.update(name.encode())
        digest.update((SOURCE_DIR / name).read_bytes())
    return digest.hexdigest()


def build_key(sources: tuple[str, ...] = SOURCES) -> str:
    return hashlib.sha256(f"{source_hash(sources)}|{engine_version()}".encode()).hexdigest()[:16]


def plugin_path() -> Path:
    return cache_root() / "contact" / build_key() / LIBRARY


def superquadric_executable_path() -> Path:
    return cache_root() / "liggghts-superquadric" / build_key(SUPERQUADRIC_SOURCES) / SUPERQUADRIC_EXECUTABLE


def ensure_plugin(force: bool = False, progress: Callable[[str], None] | None = None) -> Path:
    """Path of the built plugin, building it first when the cache has none for this source and engine."""
    return _ensure_built(plugin_path(), "build.sh", (), "the bilinear contact plugin",
                         "apt-get install libliggghts-dev mpi-default-dev g++", force, progress)


def ensure_superquadric_liggghts(force: bool = False, progress: Callable[[str], None] | None = None) -> Path:
    """Path of the LIGGGHTS executable with superquadrics and the bilinear law, building it first
    (about 6 min on 2 cores, once) when the cache has none for this source and engine version."""
    downloads = cache_root() / "liggghts-source"
    return _ensure_built(superquadric_executable_path(), "build_liggghts.sh", (str(downloads),),
                         "LIGGGHTS with superquadrics (from Debian's source)",
                         "a deb-src entry (scripts/setup.sh adds it), cmake, g++, mpi-default-dev", force, progress)


def _ensure_built(target: Path, script: str, arguments: tuple[str, ...], what: str, needs: str,
                  force: bool, progress: Callable[[str], None] | None) -> Path:
    if target.exists() and not force:
        return target
    final_dir = target.parent
    final_dir.parent.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    if progress:
        progress(f"building {what} into {final_dir} ...")
    with tempfile.TemporaryDirectory(dir=final_dir.parent, prefix=".build-") as scratch:
        result = subprocess.run(["bash", str(SOURCE_DIR / script), scratch, *arguments], capture_output=True, text=True)
        if result.returncode != 0 or not (Path(scratch) / target.name).exists():
            tail = "\n".join((result.stdout + result.stderr).strip().splitlines()[-25:])
            raise ContactBuildError(f"building {what} failed (needs: {needs}):\n" + tail)
        (Path(scratch) / "build.log").write_text(result.stdout + result.stderr)
        if final_dir.exists():
            shutil.rmtree(final_dir)
        os.replace(scratch, final_dir)
        os.makedirs(scratch, exist_ok=True)  # TemporaryDirectory cleans up a path that must exist
    if progress:
        progress(f"built in {time.perf_counter() - started:.1f} s")
    return target


def plugin_status() -> dict[str, object]:
    target = plugin_path()
    return {
        "built": target.exists(),
        "path": str(target),
        "key": target.parent.name,
        "source_hash": source_hash()[:16],
        "engine_version": engine_version(),
    }


def liggghts_env(plugin: Path) -> dict[str, str]:
    """Environment additions that make `liggghts` load the plugin."""
    preload = os.environ.get("LD_PRELOAD", "")
    return {"LD_PRELOAD": f"{plugin}:{preload}" if preload else str(plugin)}
