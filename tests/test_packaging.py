"""Packaging by today's conventions: one version, SPDX license, an sdist that can test itself."""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import pytest

import twig_ecs

ROOT = Path(__file__).resolve().parent.parent


def test_metadata_has_spdx_license_classifiers_and_one_version():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT" and project["license-files"] == ["LICENSE"]
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert "version" not in project and "version" in project["dynamic"]  # read from twig_ecs
    assert any(c.startswith("Programming Language :: Python :: 3.11") for c in project["classifiers"])
    assert any("platformdirs" in d for d in project["dependencies"])


@pytest.mark.slow  # builds the sdist and the wheel in fresh environments
def test_build_makes_an_sdist_with_docs_examples_benchmarks_tests_and_no_warning(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # not ours to warn of
    result = subprocess.run([sys.executable, "-m", "build", "--outdir", str(tmp_path), str(ROOT)],
                            capture_output=True, text=True, env=env, timeout=600)  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    output = result.stdout + result.stderr
    warnings = [line for line in output.splitlines()
                if "warning" in line.lower() and "Location 'file://" not in line]  # fmt: skip
    assert warnings == []
    version = twig_ecs.__version__
    with tarfile.open(tmp_path / f"twig_ecs-{version}.tar.gz") as sdist:
        names = sdist.getnames()
    top = f"twig_ecs-{version}"
    for needed in ("LICENSE", "docs/scenes.md", "examples/dance/test_dance.py", "benchmarks/bench_server.py",
                   "tests/conftest.py", "content/scenes/schoolyard.yaml",
                   "systems/control/gait.py"):  # fmt: skip
        assert f"{top}/{needed}" in names, needed
    with zipfile.ZipFile(tmp_path / f"twig_ecs-{version}-py3-none-any.whl") as wheel:
        files = wheel.namelist()
        metadata = wheel.read(f"twig_ecs-{version}.dist-info/METADATA").decode()
    assert "twig_ecs/content/scenes/schoolyard.yaml" in files and "twig_ecs/systems/control/gait.py" in files
    assert f"Version: {version}" in metadata and "License-Expression: MIT" in metadata
