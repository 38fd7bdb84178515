"""The contract fuzz (issue 27, point 2) over one share of the public surface: pbanim.fluids. pbanim.compare. pbanim.plotting. pbanim.bench. pbanim.course..

The machinery is tests/contract_fuzz.py; the surface is split over four files so that the test workers
(``--dist loadfile``) share it. One test per public callable with arguments.
"""

import pytest

from contract_fuzz import check_entry, entries_of, hypothesis_test

ENTRIES = entries_of(('pbanim.fluids.', 'pbanim.compare.', 'pbanim.plotting.', 'pbanim.plotting_gif.', 'pbanim.bench.', 'pbanim.course.',))


@pytest.mark.parametrize("entry", ENTRIES, ids=[e.id for e in ENTRIES])
def test_contract_fuzz(entry, fuzz_counts):
    counts = {}
    check_entry(entry, counts)
    hypothesis_test(entry)()
    fuzz_counts[f"contract: {entry.id}"] = counts.get("calls", 0)
