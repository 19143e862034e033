"""`rescene bench paper`: the tables have the paper's shapes, and the paper's numbers are labelled as such."""

from __future__ import annotations

from rescene_core.bench import SUITES
from rescene_core.bench.paper import PAPER, tables

ROW = {
    "cd": 0.07, "f5": 0.6, "nc": 0.72, "objects": 22, "oob_count": 1, "oob_rate": 1 / 22,
    "coll_pairs": 3, "coll_rate": 0.01, "anchor": 0.9, "psnr": 17.5, "ssim": 0.63, "time_min": 9.5,
}  # fmt: skip
NAMES = [
    "view_hierview", "view_largest_mask", "view_completeness_only", "relations_single_frame", "relations_vote",
    "attach_none", "attach_relations", "attach_repair", "attach_full",
]  # fmt: skip


def test_tables_have_the_papers_shapes_and_label_its_numbers():
    md = tables({n: dict(ROW) for n in NAMES}, [0], "standard")
    for title in ("Table 1", "Table 2", "Table 3(a)", "Table 3(b)", "Table 3(c)"):
        assert f"## {title}" in md
    assert (
        "| Ours (HierView, full fusion, full attachment) | 9.5 | 7.00 | 60.00 | 72.00 | 17.50 | 0.630 | not run |" in md
    )
    for name in PAPER["main"]:
        assert f"| paper: {name} |" in md
    assert "| Largest Mask | 7.00 | 60.00 | 72.00 | 9.12 | 79.49 | 79.01 |" in md
    assert "4.55%" in md  # 1 of 22 objects out of bound
    assert "ScanNet" in md and "not comparable" in md
    assert SUITES["paper"] == "rescene_core.bench.paper"
