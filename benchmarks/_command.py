"""`handvar track` timed as a user runs it: a process of its own, from its start to its exit
(Python's start-up, the imports, decoding, detection, the fit and the files written)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path


def timed_track(*args: str, env: dict | None = None) -> tuple[float, str]:
    """Run ``handvar track ARGS --no-video`` (`env`: variables set for it): its wall time
    (s) and its summary line (the one giving its frames/s all-in); exits naming the
    command if it fails."""
    handvar = Path(sys.executable).with_name("handvar")
    command = [str(handvar), "track", *map(str, args), "--no-video"]
    start = time.perf_counter()
    res = subprocess.run(command, capture_output=True, text=True, check=False,
                         env=None if env is None else {**os.environ, **env})  # fmt: skip
    seconds = time.perf_counter() - start
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed: {res.stderr.strip()[-500:]}")
    return seconds, next(x for x in res.stdout.splitlines() if "frames/s all-in" in x).strip()
