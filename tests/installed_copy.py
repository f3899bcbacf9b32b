"""Is the skidsteer the tests import the checkout's own?

`scripts/install.sh` installs a copy (a wheel: `python/skidsteer` and `models/`
under site-packages).  Edit the checkout afterwards and `python -m pytest` tests
the old copy while reporting on the new sources, which looks like a test passing
on code it never ran.  The suite's session start (conftest.py) compares the two
and stops with the files that differ; an editable install (`pip install -e .`)
imports the checkout itself and is not compared.
"""

from __future__ import annotations

import filecmp
from pathlib import Path


def _files(root: Path) -> set[Path]:
    return {p.relative_to(root) for p in root.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}


def stale_files(installed_package: Path, repo: Path) -> list[str]:
    """The checkout's files that the installed package lacks or holds in another
    version, as paths relative to the checkout (`python/skidsteer/...`, `models/...`);
    empty when the install is the checkout's.  Files only the install has (the built
    plugin library) are not differences."""
    pairs = [(repo / "python" / "skidsteer", installed_package),
             (repo / "models", installed_package / "models")]
    stale = []
    for source, copy in pairs:
        for rel in sorted(_files(source)):
            if not (copy / rel).is_file() or not filecmp.cmp(source / rel, copy / rel,
                                                             shallow=False):
                stale.append(str((source / rel).relative_to(repo)))
    return stale
