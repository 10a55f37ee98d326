"""requirements.lock: what `make setup` installs is exactly the lock, and the lock satisfies pyproject.toml."""

from __future__ import annotations

import re
import sys
import sysconfig
import tomllib
from importlib.metadata import distributions
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements.lock"
BUILT_HERE = {"simgen", "gfootball"}  # the project itself, and the engine scripts/install_engine.sh builds


def _locked() -> dict[str, tuple[Version, list[str]]]:
    """Package name -> (pinned version, its sha256 hashes), from requirements.lock."""
    text = LOCK.read_text().replace("\\\n", " ")
    pins = {}
    for line in text.splitlines():
        if not line or line[0] in "# ":
            continue
        requirement, *options = line.split(" --hash=sha256:")
        name, version = requirement.split("==")
        pins[canonicalize_name(name)] = (Version(version.strip()), [o.strip() for o in options])
    return pins


def test_the_venv_holds_exactly_the_locked_packages():
    """`pip freeze` of the set-up's venv equals the lock: same names, same versions, nothing more."""
    assert Path(sys.prefix) == ROOT / ".venv", (
        f"run the tests with the set-up's venv ({ROOT / '.venv'}), not {sys.prefix}"
    )
    # the venv's own folders, not sys.path: once imported (torch.compile on the CPU does) setuptools puts its
    # vendored packages' folder on sys.path, and their metadata would read as installed
    site = sorted({sysconfig.get_paths()[kind] for kind in ("purelib", "platlib")})
    installed = {canonicalize_name(d.metadata["Name"]): Version(d.version) for d in distributions(path=site)}
    locked = {name: version for name, (version, _) in _locked().items()}
    assert BUILT_HERE <= set(installed)
    assert {n: v for n, v in installed.items() if n not in BUILT_HERE} == locked


def test_every_pin_is_hashed_and_satisfies_pyproject():
    """Each pin carries sha256 hashes (pip refuses it otherwise), and each of pyproject.toml's requirements
    (dependencies and the test extra) is pinned at a version it allows: a changed pyproject.toml fails
    here until `make lock` is run."""
    pins = _locked()
    assert all(hashes and all(re.fullmatch("[0-9a-f]{64}", h) for h in hashes) for _, hashes in pins.values())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    for line in project["dependencies"] + project["optional-dependencies"]["test"]:
        requirement = Requirement(line)
        name = canonicalize_name(requirement.name)
        assert name in pins, f"{requirement} is not in requirements.lock: run `make lock`"
        assert requirement.specifier.contains(pins[name][0], prereleases=True), (
            f"{requirement}: the lock pins {pins[name][0]}"
        )
    assert {"pip", "setuptools", "wheel"} <= set(pins)
