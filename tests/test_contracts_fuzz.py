"""The contract fuzz over the whole public surface (issue 27, point 2); machinery in tests/contract_fuzz.py.

One test per public callable with arguments. The share of each subpackage is a separate parametrization
so that ``--dist loadfile`` spreads... (one file here: the surface is split by the ids' prefixes below).
"""

import pytest

from contract_fuzz import check_entry, entries_of, hypothesis_test

ENTRIES = entries_of(("pbanim",))


@pytest.mark.parametrize("entry", ENTRIES, ids=[e.id for e in ENTRIES])
def test_contract_fuzz(entry):
    counts = {}
    check_entry(entry, counts)
    hypothesis_test(entry)()
