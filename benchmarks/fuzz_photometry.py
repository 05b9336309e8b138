"""Fuzz the photometry readers: mutated real IES and EULUMDAT files through ``read_photometry``.

    python benchmarks/fuzz_photometry.py                    # 200,000 inputs per reader
    python benchmarks/fuzz_photometry.py --inputs 20000     # a shorter run
    python benchmarks/fuzz_photometry.py --keep out/fuzz    # keep every failing input there

Each input is one real file of ``../shared/photometry`` (the IES files for the IES reader, the
EULUMDAT files for the LDT one) with 1–4 random mutations: byte and bit flips, truncation,
deleted / duplicated / inserted ranges and lines, numeric tokens replaced by negatives, zero,
NaN, inf, huge or tiny values, empty or non-numeric text, a TILT= line naming odd paths, and
re-encoding as UTF-16. The input is written to a scratch folder and read with
``read_photometry``; the outcome is one of

* accepted: a ``Photometry`` came out; its candela table and flux are checked to be finite and
  non-negative (else it counts as *accepted-bad*, goal 0);
* refused: a ``LumijaxError`` subclass was raised (the intended outcome for bad input);
* non-project exception: anything else escaped (goal 0);
* hang: one input took longer than ``--timeout`` seconds (goal 0).

The table gives the counts; these are counts, not timings. Failing inputs are kept with
``--keep DIR`` to be reproduced with ``read_photometry``.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

from lumijax.errors import LumijaxError
from lumijax.photometry import read_photometry

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "photometry"

_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
REPLACEMENTS = [
    b"-1", b"0", b"-0", b"-0.5", b"nan", b"NaN", b"inf", b"-inf", b"1e39", b"3.5e38", b"-3e38",
    b"1e308", b"1e309", b"1e-320", b"", b" ", b"abc", b"1,5", b"99999", b"2147483648", b"1e9",
    b"3", b"2", b"1", b"360", b"180", b"90", b"-90", b"270", b"0.0001", b"1.5", b"4", b"13",
]
TILTS = [
    b"TILT=/etc/passwd", b"TILT=../../x", b"TILT=" + b"a" * 300, b"TILT=a\x00b", b"TILT=.",
    b"TILT=/", b"TILT=/dev/zero", b"TILT=INCLUDE", b"TILT=NONE", b"TILT=" + b"a/" * 3000,
    b"TILT=nofile.tlt", b"TILT=~/x", b"TILT=C:\\x.tlt",
]


class _Hang(BaseException):
    """Raised by the alarm: BaseException, so no ``except Exception`` in the reader catches it."""


def _on_alarm(signum, frame):
    raise _Hang


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One random mutation of a file's bytes."""
    n = len(data)
    op = rng.randrange(12)
    if n == 0:
        return bytes([rng.randrange(256)])
    if op == 0:  # byte flips
        b = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(n)] = rng.randrange(256)
        return bytes(b)
    if op == 1:  # bit flip
        b = bytearray(data)
        k = rng.randrange(n)
        b[k] ^= 1 << rng.randrange(8)
        return bytes(b)
    if op == 2:  # truncation
        return data[: rng.randrange(n)]
    if op == 3:  # delete a range
        a = rng.randrange(n)
        return data[:a] + data[a + rng.randint(1, 64) :]
    if op == 4:  # duplicate a range
        a = rng.randrange(n)
        return data[:a] + data[a : a + rng.randint(1, 64)] + data[a:]
    if op in (5, 6, 7):  # replace numeric tokens
        matches = list(_NUMBER.finditer(data))
        if not matches:
            return data
        out = data
        for m in sorted(rng.sample(matches, min(len(matches), rng.randint(1, 3))),
                        key=lambda m: -m.start()):
            out = out[: m.start()] + rng.choice(REPLACEMENTS) + out[m.end() :]
        return out
    lines = data.split(b"\n")
    if op == 8:  # delete, duplicate or swap lines
        i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
        what = rng.randrange(3)
        if what == 0:
            del lines[i]
        elif what == 1:
            lines.insert(i, lines[j])
        else:
            lines[i], lines[j] = lines[j], lines[i]
        return b"\n".join(lines)
    if op == 9:  # insert a line of numbers or text
        extra = b" ".join(rng.choice(REPLACEMENTS) for _ in range(rng.randint(1, 5)))
        lines.insert(rng.randrange(len(lines) + 1), extra)
        return b"\n".join(lines)
    if op == 10:  # a TILT= line naming odd paths
        for k, line in enumerate(lines):
            if line.lstrip().upper().startswith(b"TILT"):
                lines[k] = rng.choice(TILTS)
                return b"\n".join(lines)
        lines.insert(rng.randrange(len(lines) + 1), rng.choice(TILTS))
        return b"\n".join(lines)
    # op == 11: re-encode as UTF-16 (with BOM), sometimes then cut at an odd byte
    out = data.decode("latin-1").encode("utf-16")
    return out[: rng.randrange(len(out))] if rng.random() < 0.3 else out


def classify(path: Path) -> tuple[str, str]:
    """``(outcome, detail)`` of reading ``path``."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            p = read_photometry(path)
    except LumijaxError:
        return "refused", ""
    except _Hang:
        raise
    except Exception as exc:  # noqa: BLE001 - what the fuzzer is looking for
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        return "other", f"{type(exc).__name__} at {Path(tb.filename).name}:{tb.lineno}: {exc}"
    cd = np.asarray(p.distribution.candela)
    ok = bool(np.all(np.isfinite(cd)) and np.all(cd >= 0) and np.isfinite(p.integrated_lm))
    return ("accepted", "") if ok else ("accepted-bad", f"min {cd.min()} max {cd.max()}")


def run(kind: str, seeds: list[Path], n: int, rng: random.Random, timeout: float,
        scratch: Path, keep: Path | None) -> tuple[Counter, Counter]:
    counts: Counter = Counter()
    details: Counter = Counter()
    originals = [(s, s.read_bytes()) for s in seeds]
    for i in range(n):
        seed, data = rng.choice(originals)
        for _ in range(rng.randint(1, 4)):
            data = mutate(data, rng)
        path = scratch / f"input{seed.suffix}"
        path.write_bytes(data)
        start = time.perf_counter()
        signal.setitimer(signal.ITIMER_REAL, timeout)
        try:
            outcome, detail = classify(path)
        except _Hang:
            outcome, detail = "hang", f"> {timeout:g} s"
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
        del start
        counts[outcome] += 1
        if outcome in ("other", "accepted-bad", "hang"):
            details[f"{outcome}: {detail[:160]}"] += 1
            if keep is not None:
                keep.mkdir(parents=True, exist_ok=True)
                (keep / f"{kind}_{outcome}_{i}{seed.suffix}").write_bytes(data)
        if (i + 1) % max(1, n // 10) == 0:
            print(f"  {kind}: {i + 1}/{n}", file=sys.stderr, flush=True)
    return counts, details


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--inputs", type=int, default=200_000, help="inputs per reader (200000)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--timeout", type=float, default=2.0, help="seconds before an input hangs")
    ap.add_argument("--files", type=Path, default=SHARED, help="folder of real files")
    ap.add_argument("--readers", default="ies,ldt", help="ies, ldt or both (ies,ldt)")
    ap.add_argument("--keep", type=Path, default=None, help="folder for failing inputs")
    args = ap.parse_args(argv)
    if not args.files.is_dir():
        print(f"no folder of real photometric files at {args.files}", file=sys.stderr)
        return 2
    files = sorted(p for p in args.files.iterdir() if p.suffix.lower() in (".ies", ".ldt"))
    rng = random.Random(args.seed)
    signal.signal(signal.SIGALRM, _on_alarm)
    rows = []
    all_details: Counter = Counter()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="lumijax-fuzz-") as tmp:
        # The scratch file lies one folder down, so "TILT=../x" leaves the file's own folder.
        scratch = Path(tmp) / "in"
        scratch.mkdir()
        for kind in args.readers.split(","):
            seeds = [p for p in files if p.suffix.lower() == "." + kind]
            counts, details = run(kind.upper(), seeds, args.inputs, rng, args.timeout,
                                  scratch, args.keep)
            rows.append((kind.upper(), len(seeds), args.inputs, counts))
            all_details.update(details)
    wall = time.perf_counter() - t0
    print(f"\nfuzz_photometry: {args.inputs} inputs per reader, seed {args.seed}, "
          f"timeout {args.timeout:g} s, {wall:.0f} s wall, pid {os.getpid()}\n")
    print("| reader | seed files | inputs | accepted | refused (LumijaxError) "
          "| non-project exceptions | hangs | accepted with non-finite/negative |")
    print("|---|---|---|---|---|---|---|---|")
    for kind, n_seeds, n, c in rows:
        print(f"| {kind} | {n_seeds} | {n:,} | {c['accepted']:,} | {c['refused']:,} "
              f"| {c['other']:,} | {c['hang']:,} | {c['accepted-bad']:,} |")
    if all_details:
        print("\nfailures (count: outcome: detail)")
        for text, k in all_details.most_common(30):
            print(f"  {k}: {text}")
    bad = sum(c["other"] + c["hang"] + c["accepted-bad"] for *_, c in rows)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
