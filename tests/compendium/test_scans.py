"""A scan's entry in the results: it counts the cells where the statement holds and names where it flips."""


def test_scan_entry_counts_cells_and_names_the_flips():
    import pandas as pd
    from mutual.compendium.claims import check_scan
    from mutual.compendium.scans import scan_entry
    table = pd.DataFrame({"a": [1.0, 2.0, 3.0], "kind": ["x", "y", "z"], "ok": [True, False, True]})
    entry = scan_entry(table, "ok", ["a", "kind"], "table_9_scan")
    assert entry["settings"] == [2, 3] and entry["seeds"] is None and "a 2, kind y" in entry["flips"]
    assert check_scan("c9-x", entry) is entry
    assert scan_entry(table.assign(ok=True), "ok", ["a"], "t", seeds=(9, 10))["flips"] == ""
    rare = scan_entry(table.assign(ok=[False, False, True]), "ok", ["kind"], "t")
    assert rare["settings"] == [1, 3] and rare["flips"] == "holds only in 1 of 3 cells: kind z"
