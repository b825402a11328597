"""Packaging that pyproject.toml cannot say: the top-level configs/ ships inside the package.

configs/ stays at the top of the repository (DESIGN.md, Layout) and is
installed as ``gyrocomp/configs/`` (package data of ``gyrocomp.configs`` and
its folders), where :data:`gyrocomp.config.CONFIG_DIR` finds it outside a
checkout.
"""

from setuptools import find_namespace_packages, find_packages, setup

CONFIG_FOLDERS = ["gyrocomp.configs", *(f"gyrocomp.configs.{name}" for name in find_namespace_packages(where="configs"))]

setup(
    packages=[*find_packages(include=["gyrocomp", "gyrocomp.*"]), *CONFIG_FOLDERS],
    package_dir={"gyrocomp.configs": "configs"},
    package_data={folder: ["*.toml"] for folder in CONFIG_FOLDERS},
)
