"""The version lives once (core/version.py); the package metadata must carry the same one."""

import tomllib
from pathlib import Path

from roughfriction.version import __version__


def test_the_package_metadata_carries_the_code_s_version():
    pyproject = tomllib.loads((Path(__file__).resolve().parent.parent / "pyproject.toml")
                              .read_text())
    assert pyproject["project"]["version"] == __version__
