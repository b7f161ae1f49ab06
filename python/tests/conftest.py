"""Shared test helpers: where the command line and the scenes are, and the skip policy.

A test that cannot run is not a pass: locally it prints ``SKIPPED: why`` and skips; in CI
(``CI=true``) it fails, as the Rust tests do (testkit::skip).
"""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def need(ok: bool, why: str, module: bool = False) -> None:
    """Go on if ``ok``; else fail in CI, or print ``SKIPPED: why`` and skip the test (the
    whole module with ``module=True``)."""
    if ok:
        return
    if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        pytest.fail(f"cannot run in CI: {why}", pytrace=False)
    print(f"SKIPPED: {why}")
    pytest.skip(why, allow_module_level=module)


def scenes_dir() -> pathlib.Path:
    return pathlib.Path(os.environ.get("RAYSPACE_SCENES", REPO.parent / "shared" / "scenes"))


def scene_file(rel: str) -> str:
    p = scenes_dir() / rel
    need(p.is_file(), f"no scene {p} (set RAYSPACE_SCENES)")
    return str(p)


def cli() -> str:
    """The command line (``RAYSPACE_BIN``, else the workspace's release build)."""
    b = os.environ.get("RAYSPACE_BIN", str(REPO / "target" / "release" / "rayspace"))
    need(os.access(b, os.X_OK), f"no rayspace binary at {b} (cargo build --release, or set RAYSPACE_BIN)")
    return b


def run_cli(*args: str) -> str:
    r = subprocess.run([cli(), *args], capture_output=True, text=True)
    assert r.returncode == 0, f"rayspace {' '.join(args)} failed: {r.stderr}"
    return r.stdout + r.stderr
