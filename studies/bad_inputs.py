"""Run the table of bad inputs of tests/test_bad_inputs.py and count the outcomes (design §13.4).

Usage: PYTHONPATH=src python studies/bad_inputs.py [--quick]

Every case runs one command with one wrong input; a clean error is exit status 2, one
line naming the argument or the user's path, no traceback, no temporary left and every
file that existed byte-identical afterwards. Prints one line per case that is not clean
and the totals. ``--quick`` skips the cases marked slow. Then the checks beyond the
table, one line each: world points in metres (one warning line, read as mm), Ctrl-C on
a batch (``handvar: aborted`` alone) and the options and commands the library's
messages name (each exists).
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _table():
    spec = importlib.util.spec_from_file_location(
        "bad_inputs_table", HERE.parent / "tests" / "test_bad_inputs.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the slow cases")
    args = parser.parse_args()
    table = _table()
    cases = [c for c in table.CASES if not (args.quick and c.slow)]
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        root = table.make_inputs(Path(folder) / "inputs")
        print(f"inputs made in {time.perf_counter() - start:.1f} s")
        kinds: collections.Counter[str] = collections.Counter()
        per_command: collections.Counter[str] = collections.Counter()
        for case in cases:
            per_command[case.args[0]] += 1
            problems = table.run_case(case, root).problems(case, root)
            if not problems:
                kinds["clean errors"] += 1
                continue
            for problem in problems:
                kinds[problem.split(" ")[0] if "lines" not in problem else "extra lines"] += 1
            print(f"{case.id}: {'; '.join(problems)}")
        commands = ", ".join(f"{k} {v}" for k, v in sorted(per_command.items()))
        print(f"cases per command: {commands}")
        others = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items()) if k != "clean errors")
        print(
            f"{len(cases)} cases: {kinds['clean errors']} clean errors"
            + (f", {others}" if others else "")
        )
        names = table.named_options_and_commands()
        known = table.cli_option_names() | {f"handvar {c}" for c in table.main.commands}
        unknown = sorted(set(names) - known)
        for label, problems in (
            ("world points in metres", table.metres_outcome(root)),
            ("Ctrl-C on a batch", table.interrupt_outcome(root)),
            (f"{len(names)} options and commands named", [f"unknown {unknown}"] if unknown else []),
        ):
            print(f"{label}: {'; '.join(problems) or 'as documented'}")


if __name__ == "__main__":
    main()
