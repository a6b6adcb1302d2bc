"""Where the compiled engine's first call in a new process spends its time (issue 25, item 3: the load floor).

Runs one one-step ``forward_dynamics(..., engine="compiled")`` of a model whose compiled modules are on disk, under
cProfile on this thread's CPU clock, and prints the cumulative seconds of the pieces that make the floor: importing
``solutions/compiled/loops.py`` (numba's import, then its explicit-signature loops loaded from numba's cache at
import), numba's typing and target context ``refresh`` at the first load of cached code, the unserializing of the
cached libraries, and the scene's generated module.

    MBD_COMPILED_CACHE=... .venv/bin/python benchmarks/compiled_load.py course/models/double_pendulum.yaml

Run ``mbd compile`` (or any compiled run of the model) first: a module that is not cached is compiled here instead.
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

PIECES = (  # (file ending, function, label)
    ("solutions/compiled/loops.py", "<module>", "importing compiled/loops.py"),
    ("numba/__init__.py", "<module>", "importing numba (within the above)"),
    ("numba/core/caching.py", "load_overload", "cached functions loaded, loops' and scene's (load_overload)"),
    ("numba/core/base.py", "refresh", "numba's context refresh (within the above, once a process)"),
    ("numba/core/codegen.py", "_unserialize", "cached libraries unserialized (within the above)"),
    ("solutions/compiled/codegen.py", "load", "the scene's generated module (codegen.load)"),
)


def main(argv: list[str] | None = None) -> int:
    model = (argv or sys.argv[1:] or [str(ROOT / "course" / "models" / "double_pendulum.yaml")])[0]
    from solutions.assembly import build_system
    from solutions.dynamics import forward_dynamics
    from solutions.io import load_model

    system, q0, qd0 = build_system(load_model(model))
    profile = cProfile.Profile(time.thread_time)
    profile.enable()
    result = forward_dynamics(system, q0, qd0, 0.01, 1, "baumgarte", "dop853", engine="compiled")
    profile.disable()
    stats = pstats.Stats(profile).stats  # {(file, line, function): (calls, primitive, tottime, cumtime, callers)}
    total = max(entry[3] for entry in stats.values())
    print(f"first compiled call ({result.info['chosen']['engine']}, cached: {result.info['compiled']['cached']}): "
          f"{total:.3f} s of this thread's CPU")  # fmt: skip
    for ending, function, label in PIECES:
        seconds = max((e[3] for (f, _, name), e in stats.items() if f.endswith(ending) and name == function), default=0)
        print(f"{label:60s} {seconds:6.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
