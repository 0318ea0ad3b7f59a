"""Answer the ``exchange`` device's requests from a simulated gyro: a stand-in for the bench.

A real lab answers each ``request-NNNN.json`` by setting the biases on its DC source, sweeping the
analyzer and saving ``response-NNNN.csv`` (see docs/tuning-a-real-gyro.md). This script does the
same with any installed simulated device, so the whole loop can be tried without hardware::

    python examples/exchange_operator.py --dir runs/exchange --device cloverleaf --seed 1 &
    sysid tune examples/cloverleaf-exchange.toml --out runs/exchange-run

It writes each answer under a temporary name and renames it, as the protocol asks, so the
toolkit never reads half a file. Options to test the toolkit's handling of faults:
``--malformed K`` answers request K first with a file that is not a measurement (then, once the
toolkit has rejected it, with the right one); ``--error K`` answers request K with
``error-K.txt``; ``--stop-after N`` stops after N answers. ``--idle-exit S`` ends the script
S seconds after its last answer (default: run until Ctrl-C).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

from sysid_core.formats.sweepfiles import SWEEP_FORMATS, write_sweep
from sysid_core.plugin.registry import get_registry

REQUEST = re.compile(r"request-(\d{4,})\.json")


def answered(folder: Path, stem: str) -> bool:
    """Whether request ``stem`` has an answer (a response or an error) in ``folder``."""
    names = [f"response-{stem}{ext}" for ext in SWEEP_FORMATS] + [f"error-{stem}.txt"]
    return any((folder / name).exists() for name in names)


def replace_into(folder: Path, name: str, write: object) -> None:
    """Write a file under a temporary name, then rename it to ``name`` (atomic for readers)."""
    tmp = folder / f"tmp-{os.getpid()}-{name}"
    write(tmp)  # type: ignore[operator]
    os.replace(tmp, folder / name)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", required=True, help="the exchange folder ([device] dir)")
    parser.add_argument("--device", default="cloverleaf", help="a simulated device (sysid plugins)")
    parser.add_argument("--seed", type=int, default=0, help="its noise seed")
    parser.add_argument("--format", default="csv", choices=[e[1:] for e in SWEEP_FORMATS])
    parser.add_argument("--malformed", type=int, action="append", default=[], metavar="K")
    parser.add_argument("--error", type=int, action="append", default=[], metavar="K")
    parser.add_argument("--stop-after", type=int, default=None, metavar="N")
    parser.add_argument("--idle-exit", type=float, default=None, metavar="S")
    parser.add_argument("--poll", type=float, default=0.05, metavar="S")
    parser.add_argument(
        "--clock", action="store_true", help="a bench with a clock: answers carry time_s"
    )
    args = parser.parse_args(argv)
    # a line at a time, also into a pipe or a log file: whoever watches sees each answer
    if isinstance(sys.stdout, io.TextIOWrapper):
        sys.stdout.reconfigure(line_buffering=True)

    folder = Path(args.dir)
    folder.mkdir(parents=True, exist_ok=True)
    options: dict[str, object] = {"seed": args.seed}
    if args.clock:
        options["bench"] = {"clock": True}
    gyro = get_registry().device(args.device, **options)
    malformed_sent: set[int] = set()
    answers = 0
    last = time.monotonic()
    print(f"operator: answering requests in {folder} with {args.device} (seed {args.seed})")
    while True:
        for path in sorted(folder.glob("request-*.json")):
            m = REQUEST.fullmatch(path.name)
            if not m or answered(folder, m.group(1)):
                continue
            k, stem = int(m.group(1)), m.group(1)
            request = json.loads(path.read_text())
            if k in args.error:
                replace_into(
                    folder,
                    f"error-{stem}.txt",
                    lambda p: p.write_text("the analyzer reports an overload on input 2\n"),
                )
                print(f"operator: request {stem}: wrote error-{stem}.txt")
            elif k in args.malformed and k not in malformed_sent:
                malformed_sent.add(k)
                replace_into(  # a real-valued export: no imaginary columns
                    folder,
                    f"response-{stem}.csv",
                    lambda p: p.write_text("frequency_hz,y1_u1,y1_u2,y2_u1,y2_u2\n4400,1,0,0,1\n"),
                )
                print(f"operator: request {stem}: wrote a malformed response-{stem}.csv")
            else:
                f = np.asarray(request["frequencies_hz"], dtype=float)
                response = gyro.measure(request["bias_v"], f)
                name = f"response-{stem}.{args.format}"
                replace_into(folder, name, lambda p, r=response: write_sweep(p, r, "V/V"))
                print(f"operator: request {stem}: measured at {request['bias_v']} V, wrote {name}")
            answers += 1
            last = time.monotonic()
            if args.stop_after is not None and answers >= args.stop_after:
                print(f"operator: stopping after {answers} answers")
                return 0
        if args.idle_exit is not None and answers and time.monotonic() - last > args.idle_exit:
            print(f"operator: no request for {args.idle_exit:g} s; done ({answers} answers)")
            return 0
        time.sleep(args.poll)


if __name__ == "__main__":
    raise SystemExit(main())
