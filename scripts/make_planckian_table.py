"""Write lumijax/data/planckian_ohno2013.npy: the Planckian table of the CCT (Ohno 2013), rows
(T K, u, v), from the formula in ``lumijax.spectral._cie.planckian_locus``.

Run it again when the formula, the temperature cascade or the shipped CMFs change;
``tests/spectral/test_planckian_table.py`` fails until then.

    python scripts/make_planckian_table.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lumijax.spectral._cie import PLANCKIAN_FILE, planckian_locus


def main() -> None:
    out = Path(__file__).resolve().parents[1] / "lumijax" / "data" / PLANCKIAN_FILE
    table = np.ascontiguousarray(planckian_locus(), np.float64)
    np.save(out, table, allow_pickle=False)
    print(f"wrote {out} ({table.shape[0]} temperatures)")


if __name__ == "__main__":
    main()
