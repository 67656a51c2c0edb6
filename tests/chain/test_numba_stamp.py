"""numba's on-disk cache is invalidated only when the file that defines a cached function changes, not
when a function it inlines from another file does (numba's caching notes). The compiled engine's
kernels inline helpers across these files, so each of them carries one stamp: a hash of all of
them. Any edit to one changes the stamp, which must then be written into every file, so every
cached kernel is recompiled and no stale kernel can run after an edit or a partial upgrade.

Run ``python tests/chain/test_numba_stamp.py`` to write the current stamp into the files.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from pulsemap.solvers.chain.compiled_aot import SOURCES as FILES  # the compiled engine's files, listed once

CHAIN = Path(__file__).resolve().parents[2] / "solvers" / "chain"
STAMP = re.compile(r"^# numba cache stamp: ([0-9a-f]+)\n", re.M)


def expected_stamp() -> str:
    digest = hashlib.sha256()
    for name in FILES:
        digest.update(name.encode())
        digest.update(STAMP.sub("", (CHAIN / name).read_text(encoding="utf-8")).encode())
    return digest.hexdigest()[:16]


def test_every_compiled_engine_file_carries_the_stamp_of_all_of_them():
    want = expected_stamp()
    for name in FILES:
        found = STAMP.findall((CHAIN / name).read_text(encoding="utf-8"))
        assert found == [want], (f"solvers/chain/{name}: numba cache stamp {found} != {want}: an edit to the compiled "
                                 "engine needs a new stamp in every one of its files (python tests/chain/test_numba_stamp.py)")


def write_stamps() -> str:
    """Write the current stamp into every file (after the module docstring's first line block)."""
    want = expected_stamp()
    for name in FILES:
        path = CHAIN / name
        text = STAMP.sub("", path.read_text(encoding="utf-8"))
        marker = "from __future__ import annotations\n"
        assert marker in text, f"{name}: no 'from __future__ import annotations' line to put the stamp above"
        path.write_text(text.replace(marker, f"# numba cache stamp: {want}\n" + marker, 1), encoding="utf-8")
    return want


if __name__ == "__main__":
    print(write_stamps())
